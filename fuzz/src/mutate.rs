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

/// How often a drawn deep-nesting mutation (flow or block) is kept: one time in this many,
/// else a cheap mutation is drawn instead. Each makes an input of up to [`MAX_INPUT_BYTES`],
/// and drawn as often as the others they made half the inputs that large (10 kB on average,
/// a tenth at the limit), which the time per input follows; kept rare, they are still in a
/// few percent of the inputs.
const DEEP_NESTING_ODDS: u32 = 8;

fn mutate_once(data: &mut Vec<u8>, other: &[u8], rng: &mut SmallRng) {
    let mut kind = rng.gen_range(0..14);
    if matches!(kind, 8 | 9) && !rng.gen_ratio(1, DEEP_NESTING_ODDS) {
        kind = rng.gen_range(0..8);
    }
    match kind {
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
            // Deeply nested flow collections, the depth drawn log-uniformly from 100 to
            // 20,000: every order of magnitude as often, where a uniform draw made most of
            // these inputs ten thousand brackets long and the mutator's time went into them.
            let depth = (100.0_f64 * 200.0_f64.powf(rng.gen::<f64>())) as usize;
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
            // Level `l` is indented by `l` spaces, so the text grows with the square of the
            // depth: it stops at the input size limit (about 360 levels), which the result is
            // cut to anyway, instead of building megabytes to throw away.
            let depth = (50.0_f64 * 60.0_f64.powf(rng.gen::<f64>())) as usize;
            let mut text = String::from("\nbodies:\n");
            for level in (0..depth).take_while(|level| level * level / 2 < MAX_INPUT_BYTES) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The loader stage's rate follows the size of its inputs: mutation must keep them near
    /// the seeds' size, with the deep-nesting inputs (up to [`MAX_INPUT_BYTES`]) a small
    /// share. When those were drawn as often as the other mutations, mutated inputs averaged
    /// five times the seeds' size and a tenth of them were at the limit.
    #[test]
    fn mutated_inputs_stay_near_the_seeds_size() {
        let workspace = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let corpus = crate::seed_pool(&crate::load_corpus(&crate::corpus_dirs(&workspace)));
        assert!(corpus.len() >= 10, "the seed corpus is missing ({} files)", corpus.len());
        let seed_mean = corpus.iter().map(|(_, s)| s.len()).sum::<usize>() as f64 / corpus.len() as f64;
        let mut rng = SmallRng::seed_from_u64(7);
        let draws = 2000;
        let (mut total, mut at_limit) = (0usize, 0usize);
        for i in 0..draws {
            let seed = &corpus[i % corpus.len()].1;
            let other = &corpus[(i * 7 + 3) % corpus.len()].1;
            let input = mutate(seed, other, &mut rng);
            total += input.len();
            at_limit += usize::from(input.len() >= MAX_INPUT_BYTES / 2);
        }
        let mean = total as f64 / draws as f64;
        assert!(mean < 2.0 * seed_mean, "mutated inputs average {mean:.0} bytes, seeds {seed_mean:.0}");
        assert!(at_limit * 100 < draws * 3, "{at_limit} of {draws} inputs are over half the size limit");
        // The deep inputs are still drawn.
        assert!(at_limit > 0, "no deep-nesting input in {draws} draws");
    }
}
