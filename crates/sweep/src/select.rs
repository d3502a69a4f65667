//! Which points a command line names: `--point 7`, `--point 93-95,108-110`. The inverse of
//! the array specification [`crate::slurm::array_spec`] writes, so a list of unfinished points
//! (`rtsim sweep --list`) can be pasted back.

/// One entry of a point list.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entry {
    /// A single point number.
    One(usize),
    /// Every point from the first number to the second, both included.
    Range(usize, usize),
}

impl std::fmt::Display for Entry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Entry::One(k) => write!(f, "{k}"),
            Entry::Range(a, b) => write!(f, "{a}-{b}"),
        }
    }
}

const FORM: &str = "give point numbers and ranges separated by commas, e.g. 7 or 3,7-9";

/// Parse a list of numbers and inclusive ranges separated by commas (`7`, `3,7-9`), in the
/// order given.
pub fn parse(list: &str) -> Result<Vec<Entry>, String> {
    let number = |s: &str| -> Result<usize, String> {
        let s = s.trim();
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
            return Err(format!("`{s}` is not a point number"));
        }
        s.parse().map_err(|_| format!("`{s}` is too large"))
    };
    let mut entries = Vec::new();
    for part in list.split(',') {
        let entry = match part.split_once('-') {
            None => number(part).map(Entry::One),
            Some((a, b)) => match (number(a), number(b)) {
                (Ok(a), Ok(b)) if a <= b => Ok(Entry::Range(a, b)),
                (Ok(a), Ok(b)) => Err(format!("the range {a}-{b} runs backwards")),
                (Err(e), _) | (_, Err(e)) => Err(e),
            },
        };
        entries.push(entry.map_err(|e| format!("--point {list}: {e}; {FORM}"))?);
    }
    Ok(entries)
}

/// The point numbers `entries` name, in their order, given the experiment's point numbers
/// (`have`, ascending) and how many numbers it has (`numbers`, excluded grid points
/// included). A single number must be a point; a range may span excluded grid points (they
/// are skipped) but must name at least one point and end within the experiment. No point may
/// be named twice.
pub fn resolve(entries: &[Entry], have: &[usize], numbers: usize) -> Result<Vec<usize>, String> {
    let mut listed = crate::slurm::array_spec(have);
    if listed.len() > 120 {
        let cut = listed[..120].rfind(',').unwrap_or(0);
        listed.replace_range(cut.., ", …");
    }
    let mut out: Vec<usize> = Vec::new();
    let mut named = std::collections::HashSet::new();
    for &entry in entries {
        let (a, b) = match entry {
            Entry::One(k) => (k, k),
            Entry::Range(a, b) => (a, b),
        };
        if b >= numbers {
            return Err(format!(
                "--point {entry}: the experiment's points are {listed}"
            ));
        }
        let from = have.partition_point(|&k| k < a);
        let to = have.partition_point(|&k| k <= b);
        if from == to {
            return Err(match entry {
                Entry::One(_) => format!(
                    "--point {entry}: the experiment's [[exclude]] leaves that grid point out \
                     (its points: {listed})"
                ),
                Entry::Range(..) => format!(
                    "--point {entry}: the experiment's [[exclude]] leaves out every grid point \
                     of that range (its points: {listed})"
                ),
            });
        }
        for &k in &have[from..to] {
            if !named.insert(k) {
                return Err(format!("--point: point {k} is named twice"));
            }
            out.push(k);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_parse_in_order() {
        assert_eq!(parse("7").unwrap(), [Entry::One(7)]);
        assert_eq!(
            parse("9,3-5, 0").unwrap(),
            [Entry::One(9), Entry::Range(3, 5), Entry::One(0)]
        );
        assert_eq!(parse("4-4").unwrap(), [Entry::Range(4, 4)]);
    }

    #[test]
    fn malformed_lists_say_what_is_wrong_and_the_form() {
        for (list, says) in [
            ("", "`` is not a point number"),
            ("3,,4", "`` is not a point number"),
            ("x", "`x` is not a point number"),
            ("-3", "`` is not a point number"),
            ("3-", "`` is not a point number"),
            ("1-2-3", "`2-3` is not a point number"),
            ("+3", "`+3` is not a point number"),
            ("5-2", "the range 5-2 runs backwards"),
            ("99999999999999999999999", "is too large"),
        ] {
            let e = parse(list).unwrap_err();
            assert!(e.contains(says), "{list}: {e}");
            assert!(e.starts_with(&format!("--point {list}: ")), "{e}");
            assert!(e.ends_with("e.g. 7 or 3,7-9"), "{e}");
        }
    }

    #[test]
    fn resolving_skips_excluded_points_inside_ranges_only() {
        let have = [0, 1, 4, 5, 6];
        let r = |s: &str| resolve(&parse(s).unwrap(), &have, 7);
        assert_eq!(r("5,0-6").unwrap_err(), "--point: point 5 is named twice");
        assert_eq!(r("6,1-4").unwrap(), [6, 1, 4]);
        assert_eq!(r("0-6").unwrap(), [0, 1, 4, 5, 6]);
        let e = r("2").unwrap_err();
        assert!(e.contains("--point 2: the experiment's [[exclude]] leaves that grid point out (its points: 0-1,4-6)"), "{e}");
        let e = r("2-3").unwrap_err();
        assert!(e.contains("--point 2-3: the experiment's [[exclude]] leaves out every grid point of that range"), "{e}");
        let e = r("4-7").unwrap_err();
        assert_eq!(e, "--point 4-7: the experiment's points are 0-1,4-6");
        let e = r("7").unwrap_err();
        assert_eq!(e, "--point 7: the experiment's points are 0-1,4-6");
    }

    #[test]
    fn an_array_specification_reads_back() {
        let have: Vec<usize> = (0..40).filter(|k| k % 7 != 3).collect();
        let spec = crate::slurm::array_spec(&have);
        assert_eq!(resolve(&parse(&spec).unwrap(), &have, 40).unwrap(), have);
    }
}
