//! Seeded mutations of inputs (after libFuzzer's and AFL's classic mutators, without coverage
//! feedback): a run is repeatable from its seed.

use rtsim_core::Pcg32;

/// Numbers that break parsers: zero, signs, type limits, float specials.
const NUMBERS: &[&[u8]] = &[
    b"0",
    b"-1",
    b"-0",
    b"1",
    b"255",
    b"256",
    b"65536",
    b"2147483647",
    b"2147483648",
    b"4294967295",
    b"4294967296",
    b"9223372036854775807",
    b"9223372036854775808",
    b"18446744073709551615",
    b"18446744073709551616",
    b"1e39",
    b"3.4e38",
    b"-3.4e38",
    b"1e-45",
    b"nan",
    b"inf",
    b"-inf",
    b"0x",
    b"1.5.2",
    b"+",
    b"",
];

/// Bytes that break text readers: line endings, NUL, escape, invalid UTF-8.
const BYTES: &[u8] = &[
    0, b'\n', b'\r', b' ', b'\t', b'#', b'-', b'.', 0x1b, 0x7f, 0xff, 0xc3,
];

/// 32-bit words that break binary readers (little-endian): counts, NaN, infinity.
const WORDS: &[u32] = &[
    0,
    1,
    0xffff_ffff,
    0x7fff_ffff,
    0x8000_0000,
    0x7fc0_0000,
    0x7f80_0000,
    3,
];

/// Largest input the mutator produces (assumed: 64 KiB, far above every seed; bigger inputs
/// only slow the runs down).
pub const MAX_LEN: usize = 64 << 10;

/// A seeded mutator.
#[derive(Debug)]
pub struct Mutator {
    rng: Pcg32,
}

impl Mutator {
    pub fn new(seed: u64) -> Self {
        Mutator {
            rng: Pcg32::new(seed, 0xf022),
        }
    }

    fn below(&mut self, n: usize) -> usize {
        if n <= 1 {
            0
        } else {
            (self.rng.next_u64() % n as u64) as usize
        }
    }

    /// A mutant of `input`: 1–8 stacked mutations, using the target's `dict` and `other`
    /// corpus entries for splicing; `binary` adds aligned word overwrites.
    pub fn mutate(&mut self, input: &[u8], dict: &[&[u8]], other: &[u8], binary: bool) -> Vec<u8> {
        let mut b = input.to_vec();
        let rounds = 1 + self.below(8);
        for _ in 0..rounds {
            let kinds = if binary { 10 } else { 9 };
            match self.below(kinds) {
                0 => {
                    if !b.is_empty() {
                        let i = self.below(b.len());
                        b[i] ^= 1 << self.below(8);
                    }
                }
                1 => {
                    if !b.is_empty() {
                        let i = self.below(b.len());
                        b[i] = BYTES[self.below(BYTES.len())];
                    }
                }
                2 => {
                    let i = self.below(b.len() + 1);
                    let n = 1 + self.below(8);
                    let bytes: Vec<u8> = (0..n).map(|_| self.rng.next_u64() as u8).collect();
                    b.splice(i..i, bytes);
                }
                3 => {
                    if !b.is_empty() {
                        let i = self.below(b.len());
                        let n = 1 + self.below((b.len() - i).min(64));
                        b.drain(i..i + n);
                    }
                }
                4 => {
                    // Duplicate a range somewhere else (repeated elements, lines).
                    if !b.is_empty() {
                        let i = self.below(b.len());
                        let n = 1 + self.below((b.len() - i).min(256));
                        let chunk = b[i..i + n].to_vec();
                        let at = self.below(b.len() + 1);
                        b.splice(at..at, chunk);
                    }
                }
                5 => {
                    let tokens = if dict.is_empty() || self.below(2) == 0 {
                        NUMBERS
                    } else {
                        dict
                    };
                    let t = tokens[self.below(tokens.len())];
                    let i = self.below(b.len() + 1);
                    b.splice(i..i, t.iter().copied());
                }
                6 => self.replace_number(&mut b),
                7 => {
                    // Splice: our head, another input's tail.
                    if !other.is_empty() {
                        let i = self.below(b.len() + 1);
                        let j = self.below(other.len());
                        b.truncate(i);
                        b.extend_from_slice(&other[j..]);
                    }
                }
                8 => {
                    let n = self.below(b.len() + 1);
                    b.truncate(n);
                }
                _ => {
                    if b.len() >= 4 {
                        let i = self.below(b.len() / 4) * 4;
                        let w = WORDS[self.below(WORDS.len())];
                        let w = if self.below(2) == 0 {
                            w
                        } else {
                            w.swap_bytes()
                        };
                        b[i..i + 4].copy_from_slice(&w.to_le_bytes());
                    }
                }
            }
        }
        b.truncate(MAX_LEN);
        b
    }

    /// Replace one run of digits with an interesting number.
    fn replace_number(&mut self, b: &mut Vec<u8>) {
        let starts: Vec<usize> = (0..b.len())
            .filter(|&i| b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_digit()))
            .collect();
        if starts.is_empty() {
            return;
        }
        let s = starts[self.below(starts.len())];
        let e = (s..b.len())
            .find(|&i| !b[i].is_ascii_digit())
            .unwrap_or(b.len());
        let n = NUMBERS[self.below(NUMBERS.len())];
        b.splice(s..e, n.iter().copied());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mutations_are_repeatable_and_bounded() {
        let seed = b"v 1 2 3\nf 1 2 3\n";
        let run = |s| {
            let mut m = Mutator::new(s);
            (0..200)
                .map(|_| m.mutate(seed, &[b"f "], b"v 0 0 0\n", true))
                .collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
        assert!(run(9).iter().all(|m| m.len() <= MAX_LEN));
        assert!(run(9).iter().any(|m| m.as_slice() != seed));
    }
}
