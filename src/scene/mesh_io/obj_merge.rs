//! The chunks of [`super::obj_chunks`] joined into one mesh, as `tobj`
//! and [`super::obj`] make it, with the material groups of its faces.

use super::checks::{
    drop_degenerate_grouped, dropped_note, summarize, zero_normals_note, NORMALS_DROPPED,
};
use super::chunks::{lines_before, newlines};
use super::groups::GroupsBuilder;
use super::obj_chunks::{GroupStatement, Part, MAX_UNUSED_KEYWORDS, MISSING};
use super::MeshFile;
use crate::echo::echo;
use crate::geometry::Mesh;
use std::collections::HashMap;
use std::ops::Range;

/// The `usemtl` and `mtllib` statements of the chunks, in order, with their
/// lines in the file (counted only for the chunks that have some).
pub(super) fn groups(data: &[u8], chunks: &[Range<usize>], parts: &[Part]) -> GroupsBuilder {
    let mut groups = GroupsBuilder::default();
    if parts.iter().all(|p| p.groups.is_empty()) {
        return groups;
    }
    let before = lines_before(data, chunks);
    let mut triangles = 0;
    for ((p, chunk), lines) in parts.iter().zip(chunks).zip(before) {
        // Lines of the chunk before the statement's, counted on from the last.
        let (mut line, mut counted) = (lines + 1, chunk.start);
        let mut line_at = |at: usize| {
            line += newlines(&data[counted..chunk.start + at]);
            counted = chunk.start + at;
            line
        };
        for g in &p.groups {
            match g {
                GroupStatement::Use { triangle, at, name } => {
                    groups.use_material(triangles + triangle, name, line_at(*at))
                }
                GroupStatement::Library { at, name } => groups.library(name, line_at(*at)),
            }
        }
        triangles += p.tri_v.len();
    }
    groups
}

/// The merged mesh of the chunks' statements, as `tobj` and
/// [`super::obj`] make it.
pub(super) fn build(parts: Vec<Part>, groups: GroupsBuilder) -> Option<MeshFile> {
    let all = |f: fn(&Part) -> usize| parts.iter().map(f).sum::<usize>();
    let mut pos = Vec::with_capacity(all(|p| p.positions.len()));
    let mut tex = Vec::with_capacity(all(|p| p.texcoords.len()));
    let mut nor = Vec::with_capacity(all(|p| p.normals.len()));
    let triangles = all(|p| p.tri_v.len());
    // Model boundaries: an `o` or `g` after at least one face since the last.
    let mut boundaries = Vec::new();
    let mut unused: Vec<(String, usize)> = Vec::new();
    let mut offset = 0;
    for p in &parts {
        pos.extend_from_slice(&p.positions);
        tex.extend_from_slice(&p.texcoords);
        nor.extend_from_slice(&p.normals);
        boundaries.extend(p.breaks.iter().map(|b| b + offset));
        offset += p.tri_v.len();
        for (kw, n) in &p.unused {
            if let Some(e) = unused.iter_mut().find(|(k, _)| k == kw) {
                e.1 += n;
            } else if unused.len() < MAX_UNUSED_KEYWORDS {
                unused.push((kw.clone(), *n));
            }
        }
    }
    if triangles == 0 {
        return None;
    }
    // Per position: (model + 1, vt, vn, vertex) of its first corner in the
    // model; further (v, vt, vn) of the model in `more`.
    let mut first = vec![[0u32; 4]; pos.len()];
    let mut more: HashMap<[u32; 3], u32> = HashMap::new();
    let mut model = 1u32;
    let mut model_start = 0usize;
    let mut next_boundary = boundaries.iter().peekable();
    let mut positions = Vec::with_capacity(pos.len());
    let mut uvs = Vec::new();
    let mut normals = Vec::new();
    let mut with_vt = 0usize;
    let mut with_vn = 0usize;
    let mut indices = Vec::with_capacity(triangles);
    let mut t = 0usize;
    for p in &parts {
        for (j, tv) in p.tri_v.iter().enumerate() {
            let mut cut = false;
            while next_boundary.next_if(|&&b| b <= t).is_some() {
                cut = true;
            }
            if cut && t > model_start {
                model += 1;
                model_start = t;
                more.clear();
            }
            let tvt = p.tri_vt.as_ref().map_or([MISSING; 3], |l| l[j]);
            let tvn = p.tri_vn.as_ref().map_or([MISSING; 3], |l| l[j]);
            let mut tri = [0u32; 3];
            for k in 0..3 {
                let (v, vt, vn) = (tv[k], tvt[k], tvn[k]);
                let e = &mut first[v as usize];
                let found = if e[0] != model {
                    *e = [model, vt, vn, positions.len() as u32];
                    None
                } else if e[1] == vt && e[2] == vn {
                    Some(e[3])
                } else {
                    let n = positions.len() as u32;
                    match more.entry([v, vt, vn]) {
                        std::collections::hash_map::Entry::Occupied(o) => Some(*o.get()),
                        std::collections::hash_map::Entry::Vacant(s) => {
                            s.insert(n);
                            None
                        }
                    }
                };
                tri[k] = match found {
                    Some(i) => i,
                    None => {
                        let i = positions.len() as u32;
                        positions.push(pos[v as usize]);
                        if vt != MISSING {
                            with_vt += 1;
                            uvs.push(tex[vt as usize]);
                        }
                        if vn != MISSING {
                            with_vn += 1;
                            normals.push(nor[vn as usize].normalize_or_zero());
                        }
                        i
                    }
                };
            }
            indices.push(tri);
            t += 1;
        }
    }
    drop((pos, tex, nor, first, more));
    let any_uv = with_vt > 0;
    let with_uv = any_uv && with_vt == positions.len();
    let any_normal = with_vn > 0;
    let with_normals = any_normal && with_vn == positions.len();
    let mut mesh = Mesh {
        positions,
        indices,
        uvs: with_uv.then_some(uvs),
        normals: with_normals.then_some(normals),
    };
    let mut groups = groups.finish(triangles);
    let dropped = drop_degenerate_grouped(&mesh.positions, &mut mesh.indices, &mut groups);
    if mesh.indices.is_empty() {
        return None;
    }
    let uses = Uses {
        unused: &unused,
        any_uv,
        with_uv,
        any_normal,
        with_normals,
    };
    let notes = uses.notes(&mesh, dropped, triangles);
    Some(MeshFile {
        mesh,
        notes,
        groups,
    })
}

/// What of an OBJ file its mesh uses: the keywords it skipped, and whether
/// some faces, and every face, had texture coordinates and normals.
pub(super) struct Uses<'a> {
    pub unused: &'a [(String, usize)],
    pub any_uv: bool,
    pub with_uv: bool,
    pub any_normal: bool,
    pub with_normals: bool,
}

impl Uses<'_> {
    /// The notes on the file's mesh: what it did not use, what was
    /// dropped of its `triangles` faces (`dropped` degenerate ones).
    pub(super) fn notes(&self, mesh: &Mesh, dropped: usize, triangles: usize) -> Vec<String> {
        let mut notes = Vec::new();
        if !self.unused.is_empty() {
            let items: Vec<String> = self
                .unused
                .iter()
                .map(|(kw, n)| format!("{} ({n})", echo(kw)))
                .collect();
            notes.push(format!("not used: {}", summarize(&items)));
        }
        if self.any_uv && !self.with_uv {
            notes.push("texture coordinates dropped: not every face has them".into());
        }
        if self.any_normal && !self.with_normals {
            notes.push(NORMALS_DROPPED.into());
        }
        if dropped > 0 {
            notes.push(dropped_note(dropped, triangles));
        }
        notes.extend(zero_normals_note(mesh.normals.as_deref()));
        notes
    }
}
