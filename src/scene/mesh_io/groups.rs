//! The materials an OBJ file's faces ask for: its `usemtl` statements as
//! runs of consecutive triangles, and the `mtllib` libraries that define
//! them. Both OBJ readers record them through [`GroupsBuilder`], statement
//! by statement, so that they agree to the byte.

use crate::geometry::Mesh;
use std::collections::HashMap;
use std::ops::Range;

/// A name an OBJ statement gives, with the statement's line (1-based).
#[derive(Clone, Debug, PartialEq)]
pub struct Named {
    pub name: String,
    pub line: usize,
}

/// Which material each triangle of an OBJ mesh asks for. Empty for a file
/// without `usemtl` (and for PLY files).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialGroups {
    /// The `mtllib` statements, in order.
    pub libraries: Vec<Named>,
    /// Every distinct `usemtl` name, in order of first use, with the line
    /// of that use.
    pub names: Vec<Named>,
    /// Runs of consecutive triangles of one material: (first triangle,
    /// index into `names`). First triangles increase, neighbours differ in
    /// material, and no run is empty; triangles before the first run ask
    /// for no material.
    runs: Vec<(u32, u32)>,
}

impl MaterialGroups {
    /// Whether no triangle asks for a material.
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty()
    }

    /// The runs over `triangles` triangles: each range and its material,
    /// `None` for the triangles before the first `usemtl`.
    fn ranges(&self, triangles: usize) -> impl Iterator<Item = (Range<usize>, Option<u32>)> + '_ {
        let lead = self.runs.first().map_or(triangles, |r| r.0 as usize);
        let lead = (lead > 0).then_some((0..lead, None));
        let runs = self.runs.iter().enumerate().map(move |(k, &(start, id))| {
            let end = self.runs.get(k + 1).map_or(triangles, |r| r.0 as usize);
            (start as usize..end, Some(id))
        });
        lead.into_iter().chain(runs)
    }

    /// Keeps the runs in step with triangles dropped from their mesh:
    /// `dropped[t]` says whether triangle `t` went.
    pub(crate) fn drop_triangles(&mut self, dropped: &[bool]) {
        if self.runs.is_empty() {
            return;
        }
        let mut gone = 0u32;
        let mut t = 0usize;
        for run in &mut self.runs {
            while t < run.0 as usize {
                gone += dropped[t] as u32;
                t += 1;
            }
            run.0 -= gone;
        }
        let kept = dropped.len() - dropped.iter().filter(|&&d| d).count();
        self.normalize(kept);
    }

    /// Drops the runs left empty and merges neighbours of one material.
    fn normalize(&mut self, triangles: usize) {
        let mut runs: Vec<(u32, u32)> = Vec::with_capacity(self.runs.len());
        for (k, &(start, id)) in self.runs.iter().enumerate() {
            let end = self.runs.get(k + 1).map_or(triangles as u32, |r| r.0);
            if start == end {
                continue;
            }
            if runs.last().is_none_or(|last| last.1 != id) {
                runs.push((start, id));
            }
        }
        self.runs = runs;
    }

    /// `mesh` cut into one mesh per material, each with only the vertices
    /// its triangles use: (index into `names`, or `None` for the triangles
    /// before the first `usemtl`; the mesh), in order of first triangle.
    pub fn split(&self, mesh: Mesh) -> Vec<(Option<u32>, Mesh)> {
        let mut order: Vec<Option<u32>> = Vec::new();
        let mut ranges: HashMap<Option<u32>, Vec<Range<usize>>> = HashMap::new();
        for (range, id) in self.ranges(mesh.indices.len()) {
            ranges
                .entry(id)
                .or_insert_with(|| {
                    order.push(id);
                    Vec::new()
                })
                .push(range);
        }
        if order.len() <= 1 {
            return vec![(order.first().copied().flatten(), mesh)];
        }
        // Per vertex, its index in the part being built; `u32::MAX` when
        // not yet in it. Reset after each part for the vertices it touched.
        let mut remap = vec![u32::MAX; mesh.positions.len()];
        let mut parts = Vec::with_capacity(order.len());
        for id in order {
            let mut part = Mesh {
                positions: Vec::new(),
                indices: Vec::new(),
                uvs: mesh.uvs.as_ref().map(|_| Vec::new()),
                normals: mesh.normals.as_ref().map(|_| Vec::new()),
            };
            for range in &ranges[&id] {
                for tri in &mesh.indices[range.clone()] {
                    let tri = tri.map(|v| take_vertex(&mesh, &mut part, &mut remap, v));
                    part.indices.push(tri);
                }
            }
            for range in &ranges[&id] {
                for &v in mesh.indices[range.clone()].iter().flatten() {
                    remap[v as usize] = u32::MAX;
                }
            }
            parts.push((id, part));
        }
        parts
    }
}

/// The index in `part` of vertex `v` of `mesh`, copied over on first use.
fn take_vertex(mesh: &Mesh, part: &mut Mesh, remap: &mut [u32], v: u32) -> u32 {
    let slot = &mut remap[v as usize];
    if *slot == u32::MAX {
        *slot = part.positions.len() as u32;
        part.positions.push(mesh.positions[v as usize]);
        if let (Some(to), Some(from)) = (&mut part.uvs, &mesh.uvs) {
            to.push(from[v as usize]);
        }
        if let (Some(to), Some(from)) = (&mut part.normals, &mesh.normals) {
            to.push(from[v as usize]);
        }
    }
    *slot
}

/// Records the `usemtl` and `mtllib` statements of an OBJ file in order.
#[derive(Default)]
pub(super) struct GroupsBuilder {
    groups: MaterialGroups,
    ids: HashMap<String, u32>,
}

impl GroupsBuilder {
    pub(super) fn library(&mut self, name: &str, line: usize) {
        self.groups.libraries.push(Named {
            name: name.to_string(),
            line,
        });
    }

    /// A `usemtl name` on `line`, before triangle `triangle` (the count of
    /// triangles so far).
    pub(super) fn use_material(&mut self, triangle: usize, name: &str, line: usize) {
        let names = &mut self.groups.names;
        let id = *self.ids.entry(name.to_string()).or_insert_with(|| {
            names.push(Named {
                name: name.to_string(),
                line,
            });
            names.len() as u32 - 1
        });
        let runs = &mut self.groups.runs;
        if runs.last().is_some_and(|r| r.0 as usize == triangle) {
            runs.pop();
        }
        if runs.last().is_none_or(|r| r.1 != id) {
            runs.push((triangle as u32, id));
        }
    }

    /// The groups of a file of `triangles` triangles.
    pub(super) fn finish(mut self, triangles: usize) -> MaterialGroups {
        self.groups.normalize(triangles);
        self.groups
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{PackedVec3, Vec2};

    /// Materials switched before triangles 0 (a), 2 (b, then a at once),
    /// 3 (b), 5 (b again) and 6 (c, at the end: no triangle).
    fn builder() -> GroupsBuilder {
        let mut b = GroupsBuilder::default();
        b.library("x.mtl", 1);
        b.use_material(0, "a", 2);
        b.use_material(2, "b", 5);
        b.use_material(2, "a", 6);
        b.use_material(3, "b", 8);
        b.use_material(5, "b", 11);
        b.use_material(6, "c", 12);
        b
    }

    #[test]
    fn runs_merge_switches_without_triangles_and_repeats() {
        let g = builder().finish(6);
        let names: Vec<(&str, usize)> = g.names.iter().map(|n| (&*n.name, n.line)).collect();
        assert_eq!(names, [("a", 2), ("b", 5), ("c", 12)]);
        assert_eq!(g.libraries[0].name, "x.mtl");
        assert_eq!(g.runs, [(0, 0), (3, 1)]);
        let ranges: Vec<_> = g.ranges(6).collect();
        assert_eq!(ranges, [(0..3, Some(0)), (3..6, Some(1))]);
        // Triangles before the first `usemtl` ask for none.
        let mut b = GroupsBuilder::default();
        b.use_material(2, "a", 3);
        let g = b.finish(4);
        let ranges: Vec<_> = g.ranges(4).collect();
        assert_eq!(ranges, [(0..2, None), (2..4, Some(0))]);
        assert!(GroupsBuilder::default().finish(4).is_empty());
    }

    #[test]
    fn dropped_triangles_shift_and_empty_runs() {
        let mut g = builder().finish(6);
        // Triangles 0-2 are a, 3-5 b: drop all of a's, then one of b's.
        g.drop_triangles(&[true, true, true, false, true, false]);
        assert_eq!(g.runs, [(0, 1)]);
        let mut g = builder().finish(6);
        g.drop_triangles(&[false, true, false, true, false, false]);
        assert_eq!(g.runs, [(0, 0), (2, 1)]);
    }

    #[test]
    fn split_gives_each_material_its_triangles_and_only_their_vertices() {
        // A strip of 4 triangles over 6 vertices: a, b, a, none first.
        let positions: Vec<PackedVec3> = (0..6)
            .map(|i| PackedVec3::new(i as f32, (i % 2) as f32, 0.0))
            .collect();
        let uvs: Vec<Vec2> = (0..6).map(|i| Vec2::new(i as f32, 0.5)).collect();
        let mesh = Mesh {
            indices: vec![[0, 1, 2], [1, 2, 3], [2, 3, 4], [3, 4, 5]],
            uvs: Some(uvs.clone()),
            positions: positions.clone(),
            normals: None,
        };
        let mut b = GroupsBuilder::default();
        b.use_material(1, "a", 1);
        b.use_material(2, "b", 2);
        b.use_material(3, "a", 3);
        let parts = b.finish(4).split(mesh.clone());
        let ids: Vec<Option<u32>> = parts.iter().map(|p| p.0).collect();
        assert_eq!(ids, [None, Some(0), Some(1)]);
        let world = |m: &Mesh| -> Vec<[crate::math::Vec3; 3]> {
            (0..m.indices.len() as u32).map(|t| m.vertices(t)).collect()
        };
        let original = world(&mesh);
        assert_eq!(world(&parts[0].1), [original[0]]);
        assert_eq!(world(&parts[1].1), [original[1], original[3]]);
        assert_eq!(world(&parts[2].1), [original[2]]);
        // Part a uses vertices 1-5 (not 0), each once, uvs along.
        let a = &parts[1].1;
        assert_eq!(a.positions, positions[1..6]);
        assert_eq!(a.uvs.as_deref(), Some(&uvs[1..6]));
        assert!(a.normals.is_none());
        // One material for every triangle: the mesh itself, not a copy.
        let mut b = GroupsBuilder::default();
        b.use_material(0, "a", 1);
        let whole = b.finish(4).split(mesh.clone());
        assert_eq!(whole.len(), 1);
        assert_eq!(whole[0].1.indices, mesh.indices);
    }
}
