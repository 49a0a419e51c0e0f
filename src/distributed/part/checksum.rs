//! `luz:checksum`: xxh3-64 of a part's metadata and sums (see the module
//! docs of [`super`] for what goes in, and why xxh3-64).

use super::attributes::{Texts, ATTRIBUTES};
use super::PartError;
use crate::render::Film;
use std::path::Path;
use xxhash_rust::xxh3::Xxh3;

/// Versions the checksum's input; a change of what is hashed changes it.
const CHECKSUM_TAG: &[u8] = b"luz part checksum 2\0";

/// The `luz:checksum` of a part whose checksummed attributes hold `texts`
/// (in [`ATTRIBUTES`] order) and whose film is `film`.
pub(super) fn checksum(texts: &Texts, film: &Film) -> u64 {
    let mut h = Xxh3::new();
    h.update(CHECKSUM_TAG);
    for (name, text) in ATTRIBUTES.iter().zip(texts) {
        for bytes in [name.as_bytes(), text.as_bytes()] {
            h.update(bytes);
            h.update(&[0]);
        }
    }
    h.update(&film.width.to_le_bytes());
    h.update(&film.height.to_le_bytes());
    h.update(&film.samples.to_le_bytes());
    for sums in [&film.sum, &film.sum_sq] {
        if cfg!(target_endian = "little") {
            // The f64s' memory is their little-endian bytes already.
            h.update(bytemuck::cast_slice(sums));
        } else {
            for v in sums.iter().flatten() {
                h.update(&v.to_bits().to_le_bytes());
            }
        }
    }
    if let Some(plan) = &film.plan {
        for values in [&plan.count, &plan.goal] {
            for v in values {
                h.update(&v.to_le_bytes());
            }
        }
        let met: Vec<u8> = plan.met.iter().map(|&m| m as u8).collect();
        h.update(&met);
    }
    h.digest()
}

/// Refuses a part read from `path` whose attribute `texts` and `film` do
/// not give the `stored` checksum.
pub(super) fn verify_checksum(
    path: &Path,
    texts: &Texts,
    film: &Film,
    stored: u64,
) -> Result<(), PartError> {
    let computed = checksum(texts, film);
    if computed != stored {
        return Err(PartError::Checksum {
            path: path.to_path_buf(),
            stored,
            computed,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::attributes::attribute_texts;
    use super::super::tests::sample_part;
    use super::*;

    #[test]
    fn the_checksum_covers_every_sum_bit_every_attribute_and_the_shape() {
        let part = sample_part();
        let texts = attribute_texts(&part.meta, &part.film);
        let base = checksum(&texts, &part.film);
        let mut seen = vec![base];
        for bit in 0..64 {
            for sum_sq in [false, true] {
                let mut film = part.film.clone();
                let sums = if sum_sq {
                    &mut film.sum_sq
                } else {
                    &mut film.sum
                };
                sums[4][1] = f64::from_bits(sums[4][1].to_bits() ^ (1 << bit));
                seen.push(checksum(&texts, &film));
            }
        }
        for i in 0..texts.len() {
            let mut edited = texts.clone();
            edited[i].push('0');
            seen.push(checksum(&edited, &part.film));
        }
        let mut film = part.film.clone();
        (film.width, film.height) = (2, 3);
        seen.push(checksum(&texts, &film));
        let mut film = part.film.clone();
        film.samples += 1;
        seen.push(checksum(&texts, &film));
        let count = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), count, "every change gives another checksum");
    }
}
