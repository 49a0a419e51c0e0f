//! The pixel channels of a part: the mean radiance viewers show, and the
//! exact f64 sums as the high and low words of their bits (EXR has no f64
//! channels).

use super::PartError;
use crate::render::{Film, PixelPlan};
use exr::meta::attribute::SampleType;
use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, Layer, SmallVec};
use std::path::Path;

pub(super) const RGB: [&str; 3] = ["R", "G", "B"];
pub(super) const STDERR: [&str; 3] = ["stderr.R", "stderr.G", "stderr.B"];
pub(super) const COUNT: &str = "luz.count";
pub(super) const GOAL: &str = "luz.goal";
pub(super) const MET: &str = "luz.met";

fn split_bits(v: f64) -> (u32, u32) {
    let bits = v.to_bits();
    ((bits >> 32) as u32, bits as u32)
}

fn join_bits(hi: u32, lo: u32) -> f64 {
    f64::from_bits(((hi as u64) << 32) | lo as u64)
}

/// The channels of a part, adaptive or not: name and sample type.
pub(super) fn part_channels(adaptive: bool) -> Vec<(String, SampleType)> {
    let mut channels = Vec::new();
    for name in STDERR {
        channels.push((name.to_string(), SampleType::F32));
    }
    if adaptive {
        for name in [COUNT, GOAL, MET] {
            channels.push((name.to_string(), SampleType::U32));
        }
    }
    for name in RGB {
        channels.push((name.to_string(), SampleType::F32));
        for kind in ["sum", "sumsq"] {
            for word in ["hi", "lo"] {
                channels.push((format!("luz.{kind}.{name}.{word}"), SampleType::U32));
            }
        }
    }
    channels
}

/// The channels of a part holding `film`.
pub(super) fn film_channels(film: &Film) -> AnyChannels<FlatSamples> {
    let mean = film.image();
    let stderr = film.standard_error();
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in STDERR.iter().enumerate() {
        let values = stderr.pixels.iter().map(|p| p[c]).collect();
        channels.push(AnyChannel::new(*name, FlatSamples::F32(values)));
    }
    if let Some(plan) = &film.plan {
        let met = plan.met.iter().map(|&m| m as u32).collect();
        for (name, values) in [
            (COUNT, plan.count.clone()),
            (GOAL, plan.goal.clone()),
            (MET, met),
        ] {
            channels.push(AnyChannel::new(name, FlatSamples::U32(values)));
        }
    }
    for (c, name) in RGB.iter().enumerate() {
        let values = mean.pixels.iter().map(|p| p[c]).collect();
        channels.push(AnyChannel::new(*name, FlatSamples::F32(values)));
        for (kind, sums) in [("sum", &film.sum), ("sumsq", &film.sum_sq)] {
            let (hi, lo): (Vec<u32>, Vec<u32>) = sums.iter().map(|s| split_bits(s[c])).unzip();
            channels.push(AnyChannel::new(
                format!("luz.{kind}.{name}.hi").as_str(),
                FlatSamples::U32(hi),
            ));
            channels.push(AnyChannel::new(
                format!("luz.{kind}.{name}.lo").as_str(),
                FlatSamples::U32(lo),
            ));
        }
    }
    AnyChannels::sort(channels)
}

/// A film of `layer`'s size holding the sums of its channels, and for an
/// adaptive part its plan; its sample count is the caller's to set.
pub(super) fn film_of_sums(
    path: &Path,
    layer: &Layer<AnyChannels<FlatSamples>>,
    adaptive: bool,
) -> Result<Film, PartError> {
    let (width, height) = (layer.size.width(), layer.size.height());
    let n = width * height;
    let channel = |name: &str| -> Result<&Vec<u32>, PartError> {
        let found = layer.channel_data.list.iter().find(|c| c.name == *name);
        match found.map(|c| &c.sample_data) {
            Some(FlatSamples::U32(v)) if v.len() == n => Ok(v),
            Some(_) => Err(PartError::invalid(
                path,
                name,
                "expected a u32 channel".into(),
            )),
            None => Err(PartError::invalid(path, name, "channel missing".into())),
        }
    };
    let mut film = Film::try_new(width as u32, height as u32)
        .map_err(|m| PartError::invalid(path, "dataWindow", m.to_string()))?;
    for (c, name) in RGB.iter().enumerate() {
        for (kind, sums) in [("sum", &mut film.sum), ("sumsq", &mut film.sum_sq)] {
            let hi = channel(&format!("luz.{kind}.{name}.hi"))?;
            let lo = channel(&format!("luz.{kind}.{name}.lo"))?;
            for (i, s) in sums.iter_mut().enumerate() {
                s[c] = join_bits(hi[i], lo[i]);
            }
        }
    }
    if adaptive {
        let met = channel(MET)?;
        if let Some(i) = met.iter().position(|&m| m > 1) {
            return Err(PartError::invalid(
                path,
                MET,
                format!("pixel {i}: {} is not 0 or 1", met[i]),
            ));
        }
        film.plan = Some(PixelPlan {
            count: channel(COUNT)?.clone(),
            goal: channel(GOAL)?.clone(),
            met: met.iter().map(|&m| m == 1).collect(),
        });
    }
    Ok(film)
}
