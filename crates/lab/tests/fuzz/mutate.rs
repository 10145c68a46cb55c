//! Mutations of a seed file. Each input is a seed with one to four
//! mutations stacked on it; every mutation says what it did, so a saved
//! crash comes with its recipe.
//!
//! - `flip`: flip 1–8 random bits;
//! - `set`: set 1–8 random bytes to random or boundary values (0, 0xFF,
//!   `\n`, ` `, `-`, `9`, 0x7F, 0x80);
//! - `truncate`: cut the file at a random place;
//! - `dup`: copy a chunk (up to 4 KiB) to another place;
//! - `delete`: remove a chunk;
//! - `inflate`: replace an ASCII integer (most often one in the first
//!   4 KiB, where the headers and their counts are) with a huge or
//!   negative value (4294967295, 10¹², −1, …);
//! - `inflate-bin`: write a huge 16- or 32-bit value, little or big endian,
//!   at a random place — or, in a 3DS file, into a chunk's length or a
//!   vertex/face list's count;
//! - `splice`: the start of this seed, the end of another;
//! - `special`: replace a number with `nan`, `inf`, `-inf`, `1e39`, `1e309`,
//!   … (valid to some parsers and not finite, or not a number at all).

use raylab::math::SplitMix64;

/// Replacements for an ASCII integer.
const HUGE: [&str; 14] = [
    "4294967295",
    "4294967296",
    "2147483647",
    "2147483648",
    "1000000000000",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999999",
    "-1",
    "-2147483648",
    "0",
    "65535",
    "65536",
    "9223372036854775807",
];

/// Replacements for a number in a text file.
const SPECIAL: [&str; 16] = [
    "nan", "NaN", "inf", "-inf", "+inf", "1e39", "-1e39", "1e309", "-1e309", "1e-50", "1e", ".",
    "-", "infinity", "0x10", "1.5e+38",
];

/// Bytes that mean something to the parsers.
const BOUNDARY: [u8; 8] = [0, 0xFF, b'\n', b' ', b'-', b'9', 0x7F, 0x80];

/// Huge values for binary integers.
const HUGE_BIN: [u32; 6] = [0xFFFF_FFFF, 0x7FFF_FFFF, 0x8000_0000, 0xFFFF, 0x1_0000, 0];

/// A mutated input and the recipe that made it.
pub struct Mutant {
    pub bytes: Vec<u8>,
    pub recipe: Vec<String>,
}

/// Mutate `seed` (1–4 mutations); `other` is a second seed for splices.
pub fn mutate(rng: &mut SplitMix64, seed: &[u8], other: &[u8]) -> Mutant {
    let mut bytes = seed.to_vec();
    let mut recipe = Vec::new();
    let n = 1 + rng.below(4);
    for _ in 0..n {
        recipe.push(mutate_once(rng, &mut bytes, other));
    }
    Mutant { bytes, recipe }
}

fn mutate_once(rng: &mut SplitMix64, b: &mut Vec<u8>, other: &[u8]) -> String {
    if b.is_empty() {
        b.extend_from_slice(&other[..other.len().min(64)]);
        return "refill from the other seed".into();
    }
    let len = b.len();
    match rng.below(10) {
        0 => {
            let k = 1 + rng.below(8);
            let mut at = Vec::new();
            for _ in 0..k {
                let i = rng.below(len);
                b[i] ^= 1 << rng.below(8);
                at.push(i);
            }
            format!("flip bits at {at:?}")
        }
        1 => {
            let k = 1 + rng.below(8);
            let mut at = Vec::new();
            for _ in 0..k {
                let i = rng.below(len);
                b[i] = if rng.below(2) == 0 {
                    BOUNDARY[rng.below(BOUNDARY.len())]
                } else {
                    rng.next_u64() as u8
                };
                at.push((i, b[i]));
            }
            format!("set bytes (offset, value) {at:?}")
        }
        2 => {
            let at = head_biased(rng, len);
            b.truncate(at);
            format!("truncate to {at} bytes")
        }
        3 => {
            let start = rng.below(len);
            let n = 1 + rng.below((len - start).min(4096));
            let chunk = b[start..start + n].to_vec();
            let to = rng.below(len + 1);
            b.splice(to..to, chunk);
            format!("duplicate {n} bytes from {start} to {to}")
        }
        4 => {
            let start = rng.below(len);
            let n = 1 + rng.below((len - start).min(256));
            b.drain(start..start + n);
            format!("delete {n} bytes at {start}")
        }
        5 | 6 => inflate_text(rng, b).unwrap_or_else(|| inflate_binary(rng, b)),
        7 => inflate_binary(rng, b),
        8 => {
            let cut = rng.below(len + 1);
            let from = rng.below(other.len() + 1);
            // Keep a splice from growing an input without bound.
            let take = (other.len() - from).min(1 << 16);
            b.truncate(cut);
            b.extend_from_slice(&other[from..from + take]);
            format!("splice: first {cut} bytes, then {take} bytes of the other seed from {from}")
        }
        _ => special_number(rng, b).unwrap_or_else(|| {
            let i = rng.below(len);
            b[i] = b'.';
            format!("set byte {i} to `.`")
        }),
    }
}

/// A position, most often in the first 4 KiB (the header).
fn head_biased(rng: &mut SplitMix64, len: usize) -> usize {
    if rng.below(4) != 0 {
        rng.below(len.min(4096) + 1)
    } else {
        rng.below(len + 1)
    }
}

/// The next run of ASCII digits (with a leading `-`) at or after `from`.
fn next_integer(b: &[u8], from: usize) -> Option<(usize, usize)> {
    let start = from + b.get(from..)?.iter().position(u8::is_ascii_digit)?;
    let end = start
        + b[start..]
            .iter()
            .position(|c| !c.is_ascii_digit())
            .unwrap_or(b.len() - start);
    let start = if start > 0 && b[start - 1] == b'-' {
        start - 1
    } else {
        start
    };
    Some((start, end))
}

fn inflate_text(rng: &mut SplitMix64, b: &mut Vec<u8>) -> Option<String> {
    let from = head_biased(rng, b.len());
    let (start, end) = next_integer(b, from).or_else(|| next_integer(b, 0))?;
    let old = String::from_utf8_lossy(&b[start..end]).into_owned();
    let new = match rng.below(HUGE.len() + 2) {
        i if i < HUGE.len() => HUGE[i].to_string(),
        i if i == HUGE.len() => old
            .parse::<i128>()
            .map_or("1".into(), |v| v.saturating_mul(2).to_string()),
        _ => old
            .parse::<i128>()
            .map_or("1".into(), |v| v.saturating_add(1).to_string()),
    };
    b.splice(start..end, new.bytes());
    Some(format!("inflate integer `{old}` at {start} to `{new}`"))
}

fn inflate_binary(rng: &mut SplitMix64, b: &mut [u8]) -> String {
    let value = HUGE_BIN[rng.below(HUGE_BIN.len())];
    // In a 3DS file, aim at a chunk length or a list count half the time.
    let chunks = chunk_fields(b);
    let (at, width) = if !chunks.is_empty() && rng.below(2) == 0 {
        chunks[rng.below(chunks.len())]
    } else {
        let width = if rng.below(2) == 0 { 2 } else { 4 };
        (rng.below(b.len()), width)
    };
    let big_endian = chunks.is_empty() && rng.below(2) == 0;
    let bytes: Vec<u8> = match (width, big_endian) {
        (2, false) => (value as u16).to_le_bytes().to_vec(),
        (2, true) => (value as u16).to_be_bytes().to_vec(),
        (_, false) => value.to_le_bytes().to_vec(),
        (_, true) => value.to_be_bytes().to_vec(),
    };
    let n = bytes.len().min(b.len() - at);
    b[at..at + n].copy_from_slice(&bytes[..n]);
    format!(
        "write {value:#x} as a {}-bit {} integer at {at}",
        width * 8,
        if big_endian {
            "big-endian"
        } else {
            "little-endian"
        }
    )
}

/// In a 3DS file (it starts with chunk 0x4D4D), the offsets of the length
/// field of every chunk the reader descends into, and of the count of every
/// vertex and face list, each with its width in bytes.
fn chunk_fields(b: &[u8]) -> Vec<(usize, usize)> {
    let mut fields = Vec::new();
    if b.len() >= 6 && b[0..2] == [0x4D, 0x4D] {
        walk(b, 0, b.len(), &mut fields, 0);
    }
    fields
}

fn walk(b: &[u8], mut pos: usize, end: usize, fields: &mut Vec<(usize, usize)>, depth: u32) {
    while pos + 6 <= end && depth < 8 && fields.len() < 4096 {
        let id = u16::from_le_bytes([b[pos], b[pos + 1]]);
        let len = u32::from_le_bytes([b[pos + 2], b[pos + 3], b[pos + 4], b[pos + 5]]) as usize;
        if len < 6 || len > end - pos {
            return;
        }
        fields.push((pos + 2, 4));
        let data = pos + 6;
        match id {
            0x4D4D | 0x3D3D | 0x4100 => walk(b, data, pos + len, fields, depth + 1),
            0x4000 => {
                if let Some(nul) = b[data..pos + len].iter().position(|&c| c == 0) {
                    walk(b, data + nul + 1, pos + len, fields, depth + 1);
                }
            }
            0x4110 | 0x4120 => fields.push((data, 2)),
            _ => {}
        }
        pos += len;
    }
}

/// Replace a number (a run of digits, `.`, `e`, `+`, `-`) with a special
/// token.
fn special_number(rng: &mut SplitMix64, b: &mut Vec<u8>) -> Option<String> {
    let from = head_biased(rng, b.len());
    let (start, _) = next_integer(b, from).or_else(|| next_integer(b, 0))?;
    let number = |c: &u8| c.is_ascii_digit() || matches!(c, b'.' | b'e' | b'E' | b'+' | b'-');
    let end = start
        + b[start..]
            .iter()
            .position(|c| !number(c))
            .unwrap_or(b.len() - start);
    let token = SPECIAL[rng.below(SPECIAL.len())];
    let old = String::from_utf8_lossy(&b[start..end]).into_owned();
    b.splice(start..end, token.bytes());
    Some(format!("replace number `{old}` at {start} with `{token}`"))
}
