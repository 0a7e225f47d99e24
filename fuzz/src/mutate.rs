//! Byte-level mutation of the seed corpus: flips, insertions and deletions of bytes and
//! ranges, YAML-significant characters, line shuffles, splices of two seeds, interesting
//! numbers in place of numbers, and deeply nested flow collections and block indentation
//! (the classic way to overflow a recursive parser's stack).

use rand::rngs::SmallRng;
use rand::Rng;

/// Characters that change a YAML document's structure.
const SIGNIFICANT: &[u8] = b":-[]{},#&*!|>'\"%@`? \n\t\\.0123456789";

/// Replacement texts for a number.
const NUMBERS: [&str; 14] = [
    "0",
    "-0",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    ".nan",
    ".inf",
    "-.inf",
    "4294967296",
    "0x7f",
    "1_000",
    "99999999999999999999999",
    "~",
];

/// The largest input the mutator produces, bytes. Model files are a few KiB; the time limit
/// per input is meant for files of a plausible size (the loader is linear in the input's
/// size: a multi-megabyte file takes seconds to reject, which is not a hang).
pub const MAX_INPUT_BYTES: usize = 64 * 1024;

/// Applies 1–8 random mutations to `seed`, sometimes splicing in part of `other`; the
/// result is cut to [`MAX_INPUT_BYTES`].
pub fn mutate(seed: &[u8], other: &[u8], rng: &mut SmallRng) -> Vec<u8> {
    let mut data = seed.to_vec();
    let rounds = rng.gen_range(1..=8);
    for _ in 0..rounds {
        mutate_once(&mut data, other, rng);
        data.truncate(MAX_INPUT_BYTES);
    }
    data
}

fn position(data: &[u8], rng: &mut SmallRng) -> usize {
    if data.is_empty() {
        0
    } else {
        rng.gen_range(0..=data.len())
    }
}

fn mutate_once(data: &mut Vec<u8>, other: &[u8], rng: &mut SmallRng) {
    match rng.gen_range(0..14) {
        0 if !data.is_empty() => {
            let i = rng.gen_range(0..data.len());
            data[i] ^= 1 << rng.gen_range(0..8);
        }
        1 if !data.is_empty() => {
            let i = rng.gen_range(0..data.len());
            data[i] = SIGNIFICANT[rng.gen_range(0..SIGNIFICANT.len())];
        }
        2 => {
            let i = position(data, rng);
            data.insert(i, SIGNIFICANT[rng.gen_range(0..SIGNIFICANT.len())]);
        }
        3 if !data.is_empty() => {
            let i = rng.gen_range(0..data.len());
            let len = rng.gen_range(1..=64.min(data.len() - i));
            data.drain(i..i + len);
        }
        4 if !data.is_empty() => {
            // Duplicate a range in place.
            let i = rng.gen_range(0..data.len());
            let len = rng.gen_range(1..=256.min(data.len() - i));
            let chunk: Vec<u8> = data[i..i + len].to_vec();
            let at = position(data, rng);
            data.splice(at..at, chunk);
        }
        5 => {
            // Swap two lines.
            let mut lines: Vec<Vec<u8>> = data.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
            if lines.len() > 1 {
                let a = rng.gen_range(0..lines.len());
                let b = rng.gen_range(0..lines.len());
                lines.swap(a, b);
                *data = lines.join(&b'\n');
            }
        }
        6 if !other.is_empty() => {
            // Splice: our head, the other's tail.
            let cut = position(data, rng);
            let from = rng.gen_range(0..other.len());
            data.truncate(cut);
            data.extend_from_slice(&other[from..]);
        }
        7 => {
            // Replace a number with an interesting one.
            let starts: Vec<usize> = (0..data.len())
                .filter(|&i| data[i].is_ascii_digit() && (i == 0 || !data[i - 1].is_ascii_alphanumeric()))
                .collect();
            if let Some(&start) = starts.get(rng.gen_range(0..starts.len().max(1))) {
                let mut end = start;
                while end < data.len() && matches!(data[end], b'0'..=b'9' | b'.' | b'e' | b'E' | b'-' | b'+')
                {
                    end += 1;
                }
                let text = NUMBERS[rng.gen_range(0..NUMBERS.len())];
                data.splice(start..end, text.bytes());
            }
        }
        8 => {
            // Deeply nested flow collections.
            let depth = rng.gen_range(100..20_000);
            let open = if rng.gen_bool(0.5) { b'[' } else { b'{' };
            let at = position(data, rng);
            let mut nest = vec![open; depth];
            if rng.gen_bool(0.5) {
                nest.extend(std::iter::repeat_n(if open == b'[' { b']' } else { b'}' }, depth));
            }
            data.splice(at..at, nest);
        }
        9 => {
            // Deeply nested block sequences / mappings.
            let depth = rng.gen_range(50..3_000);
            let mut text = String::from("\nbodies:\n");
            for level in 0..depth {
                text.push_str(&" ".repeat(level));
                text.push_str(if level % 2 == 0 { "- " } else { "k:\n" });
                text.push('\n');
            }
            let at = position(data, rng);
            data.splice(at..at, text.bytes());
        }
        10 => {
            // Anchors and aliases (including a self-referencing alias and a billion laughs).
            let snippets: [&[u8]; 4] = [
                b"\nx: &a [1, 2]\ny: *a\n",
                b"\nx: &a\n  y: *a\n",
                b"\na: &a [1,1,1,1,1,1,1,1,1]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\nc: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]\nd: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c]\ne: [*d,*d,*d,*d,*d,*d,*d,*d,*d]\n",
                b"\n<<: *undefined\n",
            ];
            let snippet = snippets[rng.gen_range(0..snippets.len())];
            let at = position(data, rng);
            data.splice(at..at, snippet.iter().copied());
        }
        11 => {
            // Tags, invalid UTF-8, BOM, NUL.
            let snippets: [&[u8]; 6] =
                [b"!!binary ", b"!custom ", b"\xff\xfe", b"\xef\xbb\xbf", b"\0", b"\r\n"];
            let snippet = snippets[rng.gen_range(0..snippets.len())];
            let at = position(data, rng);
            data.splice(at..at, snippet.iter().copied());
        }
        12 if !data.is_empty() => {
            // Change the indentation of one line.
            let lines: Vec<usize> = (0..data.len()).filter(|&i| i == 0 || data[i - 1] == b'\n').collect();
            let start = lines[rng.gen_range(0..lines.len())];
            if rng.gen_bool(0.5) {
                data.splice(start..start, std::iter::repeat_n(b' ', rng.gen_range(1..5)));
            } else if data.get(start) == Some(&b' ') {
                data.remove(start);
            }
        }
        _ => {
            // Truncate.
            let cut = position(data, rng);
            data.truncate(cut);
        }
    }
}
