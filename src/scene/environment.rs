//! Light from infinitely far away: a constant radiance, or a
//! latitude-longitude map evaluated exactly as Mitsuba 3's `envmap`
//! (direction to uv, periodic bilinear lookup in φ, rows at the poles),
//! with `scale` and a rotation `to_world`. Both are importance-sampled, so
//! next-event estimation finds them; the map in proportion to luminance ×
//! sin θ over its texels, the constant uniformly over the sphere.

use crate::math::{luminance, Mat3, Rgb, Vec2, Vec3};
use crate::sampling::{uniform_sphere, Discrete, UNIFORM_SPHERE_PDF};
use std::f32::consts::PI;

#[derive(Clone, Debug)]
pub enum Environment {
    Constant(Rgb),
    Map(EnvMap),
}

/// A direction towards the environment, the radiance arriving from it and
/// its solid-angle pdf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    pub wi: Vec3,
    pub radiance: Rgb,
    pub pdf: f32,
}

impl Environment {
    /// Radiance arriving along `-dir` (a ray escaping with direction `dir`).
    pub fn eval(&self, dir: Vec3) -> Rgb {
        match self {
            Environment::Constant(c) => *c,
            Environment::Map(m) => m.eval(dir),
        }
    }

    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        match self {
            Environment::Constant(c) if c.max_element() > 0.0 => Some(EnvSample {
                wi: uniform_sphere(u),
                radiance: *c,
                pdf: UNIFORM_SPHERE_PDF,
            }),
            Environment::Constant(_) => None,
            Environment::Map(m) => m.sample(u),
        }
    }

    /// The solid-angle pdf with which `sample` picks `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match self {
            Environment::Constant(c) if c.max_element() > 0.0 => UNIFORM_SPHERE_PDF,
            Environment::Constant(_) => 0.0,
            Environment::Map(m) => m.pdf(dir),
        }
    }
}

#[derive(Clone, Debug)]
pub struct EnvMap {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row 0 at the +y pole (θ = 0) of the map's own frame.
    pub texels: Vec<Rgb>,
    pub scale: f32,
    /// The map's frame in the world (a rotation).
    pub to_world: Mat3,
    to_local: Mat3,
    /// Rows of uv cells, then the cells of each row (`None`: a black row).
    rows: Option<Discrete>,
    columns: Vec<Option<Discrete>>,
}

impl EnvMap {
    pub fn new(width: u32, height: u32, texels: Vec<Rgb>, scale: f32, to_world: Mat3) -> Self {
        let mut map = Self {
            width,
            height,
            texels,
            scale,
            to_world,
            to_local: to_world.inverse(),
            rows: None,
            columns: Vec::new(),
        };
        let (w, h) = (width as f32, height as f32);
        let mut row_weights = Vec::with_capacity(height as usize);
        for y in 0..height {
            let v = (y as f32 + 0.5) / h;
            let sin_theta = (v * PI).sin();
            let cells: Vec<f32> = (0..width)
                .map(|x| luminance(map.lookup(Vec2::new((x as f32 + 0.5) / w, v))) * sin_theta)
                .collect();
            let row = Discrete::new(cells);
            row_weights.push(row.as_ref().map_or(0.0, |d| d.total() as f32));
            map.columns.push(row);
        }
        map.rows = Discrete::new(row_weights);
        map
    }

    /// Mitsuba's bilinear lookup (without `scale`): texel-centred columns,
    /// periodic in φ; rows at θ = yπ/(H − 1), clamped.
    fn lookup(&self, uv: Vec2) -> Rgb {
        let (w, h) = (self.width as usize, self.height as usize);
        let u = uv.x - uv.x.floor();
        let fx = u * w as f32 - 0.5;
        let fy = uv.y.clamp(0.0, 1.0) * (h - 1) as f32;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (wx, wy) = (fx - x0, fy - y0);
        let x0 = (x0 as i64).rem_euclid(w as i64) as usize;
        let x1 = (x0 + 1) % w;
        let y0 = (y0 as usize).min(h - 1);
        let y1 = (y0 + 1).min(h - 1);
        let at = |x: usize, y: usize| self.texels[y * w + x];
        let top = at(x0, y0) * (1.0 - wx) + at(x1, y0) * wx;
        let bottom = at(x0, y1) * (1.0 - wx) + at(x1, y1) * wx;
        top * (1.0 - wy) + bottom * wy
    }

    fn eval(&self, dir: Vec3) -> Rgb {
        self.lookup(direction_to_uv(self.to_local * dir)) * self.scale
    }

    fn sample(&self, u: Vec2) -> Option<EnvSample> {
        let (row, p_row, v) = self.rows.as_ref()?.sample_reuse(u.y);
        let (column, p_column, u) = self.columns[row].as_ref()?.sample_reuse(u.x);
        let uv = Vec2::new(
            (column as f32 + u) / self.width as f32,
            (row as f32 + v) / self.height as f32,
        );
        let (sin_theta, cos_theta) = (uv.y * PI).sin_cos();
        if sin_theta <= 0.0 {
            return None;
        }
        let (sin_phi, cos_phi) = (uv.x * 2.0 * PI).sin_cos();
        let local = Vec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta);
        let density = p_row * p_column * (self.width * self.height) as f32;
        Some(EnvSample {
            wi: (self.to_world * local).normalize(),
            radiance: self.lookup(uv) * self.scale,
            pdf: density / (2.0 * PI * PI * sin_theta),
        })
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        let Some(rows) = &self.rows else {
            return 0.0;
        };
        let uv = direction_to_uv(self.to_local * dir);
        let sin_theta = (uv.y * PI).sin();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let cell = |t: f32, n: u32| ((t * n as f32) as usize).min(n as usize - 1);
        let (row, column) = (cell(uv.y, self.height), cell(uv.x, self.width));
        let Some(columns) = &self.columns[row] else {
            return 0.0;
        };
        let density = rows.pmf(row) * columns.pmf(column) * (self.width * self.height) as f32;
        density / (2.0 * PI * PI * sin_theta)
    }
}

/// Mitsuba's latitude-longitude coordinates of a unit direction in the
/// map's frame: u = atan2(x, −z)/2π (wrapped into [0, 1)), v = acos(y)/π.
fn direction_to_uv(d: Vec3) -> Vec2 {
    let u = d.x.atan2(-d.z) * (0.5 / PI);
    Vec2::new(u - u.floor(), d.y.clamp(-1.0, 1.0).acos() / PI)
}

#[cfg(test)]
mod tests;
