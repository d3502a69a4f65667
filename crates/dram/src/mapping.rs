//! Address mapping: a physical byte address → channel, rank, bank group, bank, row, column.
//!
//! A mapping is an ordered list of bit slices, most significant first, e.g.
//! `row:rank:bank:channel:column:offset`. Each field takes `log2` of its count in bits
//! (`column` counts lines within a row, `offset` the bytes of a line); a field may be split into
//! several slices with explicit widths, `row:column(3):bank:channel:column(4):offset`, the
//! earlier slice holding the higher bits. DRAMsim3-style strings (`rochrababgco`: two letters per
//! field, offset implied below) are accepted too. Optionally the bank index is XORed with the
//! low row bits (permutation-based interleaving). Bits above the capacity are ignored.
//!
//! Errors name the `mapping` key and say which field's bits do not add up.

use crate::config::Organisation;
use rtsim_config::ConfigError;

/// A decoded location inside the memory system.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Location {
    pub channel: u32,
    pub rank: u32,
    /// Bank group within the rank.
    pub bank_group: u32,
    /// Bank index within the rank, across groups: `bank_group × banks_per_group + bank`.
    pub bank: u32,
    pub row: u32,
    /// Line-sized column index within the row.
    pub column: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Field {
    Channel,
    Rank,
    BankGroup,
    Bank,
    Row,
    Column,
    Offset,
}

impl Field {
    const ALL: [Field; 7] = [
        Field::Channel,
        Field::Rank,
        Field::BankGroup,
        Field::Bank,
        Field::Row,
        Field::Column,
        Field::Offset,
    ];
    fn name(self) -> &'static str {
        match self {
            Field::Channel => "channel",
            Field::Rank => "rank",
            Field::BankGroup => "bankgroup",
            Field::Bank => "bank",
            Field::Row => "row",
            Field::Column => "column",
            Field::Offset => "offset",
        }
    }
    fn parse(s: &str) -> Option<Field> {
        Some(match s {
            "channel" | "ch" => Field::Channel,
            "rank" | "ra" => Field::Rank,
            "bankgroup" | "bank_group" | "bg" => Field::BankGroup,
            "bank" | "ba" => Field::Bank,
            "row" | "ro" => Field::Row,
            "column" | "col" | "co" => Field::Column,
            "offset" | "off" => Field::Offset,
            _ => return None,
        })
    }
}

/// One slice: `width` bits of the address at `shift` go to bit `dest` of the field.
#[derive(Clone, Copy, Debug)]
struct Slice {
    field: Field,
    shift: u32,
    width: u32,
    dest: u32,
}

/// Decodes addresses for one organisation and mapping.
#[derive(Clone, Debug)]
pub struct AddressMapper {
    slices: Vec<Slice>,
    /// Where every field is at most one slice (the usual case): each field's shift and mask
    /// by `Field` index (mask 0 for an absent field), so decoding is a fixed shift and mask per
    /// field instead of a pass over the slices.
    whole_fields: Option<[(u32, u32); 6]>,
    line_shift: u32,
    banks_per_group: u32,
    /// True when the mapping names `bankgroup` separately from `bank`.
    split_groups: bool,
    bank_xor: bool,
    bank_mask: u32,
    total_bits: u32,
    text: String,
}

fn bad(msg: impl std::fmt::Display) -> ConfigError {
    ConfigError::key("mapping", msg)
}

/// Split a DRAMsim3 string like `rochrababgco` into field tokens, or `None` if it is not one.
fn dramsim3_tokens(s: &str) -> Option<Vec<String>> {
    if s.contains(':') || s.len() % 2 != 0 || s.is_empty() {
        return None;
    }
    let mut out = Vec::new();
    for i in (0..s.len()).step_by(2) {
        let t = s.get(i..i + 2)?;
        Field::parse(t)?;
        out.push(t.to_string());
    }
    out.push("offset".into());
    Some(out)
}

impl AddressMapper {
    /// Parse `text` for organisation `org`. Errors name the `mapping` key.
    pub fn new(text: &str, bank_xor: bool, org: &Organisation) -> Result<Self, ConfigError> {
        let banks = org.bank_groups * org.banks_per_group;
        let row_bytes = u64::from(org.columns) * u64::from(org.bus_width / 8);
        let lines_per_row = row_bytes / u64::from(org.line_bytes);
        let tokens: Vec<String> = match dramsim3_tokens(text.trim()) {
            Some(t) => t,
            None => text.split(':').map(|t| t.trim().to_string()).collect(),
        };
        // Parse tokens into (field, explicit width).
        let mut parsed: Vec<(Field, Option<u32>)> = Vec::new();
        for tok in &tokens {
            if tok.is_empty() {
                return Err(bad(format!("empty field in `{text}`")));
            }
            let (name, width) = match tok.split_once('(') {
                Some((n, rest)) => {
                    let w = rest
                        .strip_suffix(')')
                        .and_then(|w| w.trim().parse::<u32>().ok())
                        .ok_or_else(|| {
                            bad(format!("`{tok}`: expected field(bits), e.g. column(3)"))
                        })?;
                    (n.trim(), Some(w))
                }
                None => (tok.as_str(), None),
            };
            let field = Field::parse(&name.to_ascii_lowercase()).ok_or_else(|| {
                bad(format!(
                    "unknown field `{name}` in `{text}`; known: channel, rank, bankgroup, bank, \
                     row, column, offset"
                ))
            })?;
            parsed.push((field, width));
        }
        let split_groups = parsed.iter().any(|(f, _)| *f == Field::BankGroup);
        let need = |f: Field| -> u32 {
            let n: u64 = match f {
                Field::Channel => u64::from(org.channels),
                Field::Rank => u64::from(org.ranks),
                Field::BankGroup => u64::from(org.bank_groups),
                Field::Bank if split_groups => u64::from(org.banks_per_group),
                Field::Bank => u64::from(banks),
                Field::Row => u64::from(org.rows),
                Field::Column => lines_per_row,
                Field::Offset => u64::from(org.line_bytes),
            };
            n.trailing_zeros()
        };
        // Widths per field must add up to what the organisation needs.
        for f in Field::ALL {
            let occ: Vec<Option<u32>> = parsed
                .iter()
                .filter(|(g, _)| *g == f)
                .map(|(_, w)| *w)
                .collect();
            let want = need(f);
            if f == Field::BankGroup && !split_groups {
                continue;
            }
            if occ.is_empty() {
                if want > 0 {
                    return Err(bad(format!(
                        "`{text}` has no `{}` field, which needs {want} bits here",
                        f.name()
                    )));
                }
                continue;
            }
            if occ.len() > 1 && occ.iter().any(Option::is_none) {
                return Err(bad(format!(
                    "`{}` appears {} times in `{text}`: give every slice a width, e.g. {}(2)",
                    f.name(),
                    occ.len(),
                    f.name()
                )));
            }
            if let Some(&Some(w)) = occ.iter().find(|w| w.is_some_and(|w| w > want)) {
                return Err(bad(format!(
                    "a slice of `{}` in `{text}` has {w} bits, but the field has only {want}",
                    f.name()
                )));
            }
            let given: u32 = occ.iter().map(|w| w.unwrap_or(want)).sum();
            if given != want {
                return Err(bad(format!(
                    "the slices of `{}` in `{text}` have {given} bits, but {want} are needed \
                     (the organisation's address bits do not add up)",
                    f.name()
                )));
            }
        }
        if parsed.last().map(|(f, _)| *f) != Some(Field::Offset) {
            return Err(bad(format!(
                "`{text}` must end with `offset` (the line's byte offset is the least \
                 significant field)"
            )));
        }
        if parsed.iter().filter(|(f, _)| *f == Field::Offset).count() > 1 {
            return Err(bad(format!("`offset` appears more than once in `{text}`")));
        }
        // Assign address bit positions from the least significant slice upwards; within a
        // field, later (less significant) slices take the lower bits.
        let mut slices = Vec::new();
        let mut shift = 0u32;
        let mut filled = [0u32; 7];
        for &(field, w) in parsed.iter().rev() {
            let width = w.unwrap_or_else(|| need(field));
            slices.push(Slice {
                field,
                shift,
                width,
                dest: filled[field as usize],
            });
            filled[field as usize] += width;
            shift += width;
        }
        slices.retain(|s| s.width > 0 && s.field != Field::Offset);
        let mut whole = [(0u32, 0u32); 6];
        let mut whole_ok = true;
        for s in &slices {
            let f = &mut whole[s.field as usize];
            // Widths are at most 22 bits (rows; `config::Organisation`'s limits).
            whole_ok &= f.1 == 0 && s.dest == 0 && s.width < 32;
            *f = (s.shift, (1u32 << s.width.min(31)) - 1);
        }
        Ok(AddressMapper {
            whole_fields: whole_ok.then_some(whole),
            slices,
            line_shift: need(Field::Offset),
            banks_per_group: org.banks_per_group,
            split_groups,
            bank_xor,
            bank_mask: banks - 1,
            total_bits: shift,
            text: text.to_string(),
        })
    }

    /// Bits of address decoded (log2 of the capacity in bytes).
    pub fn address_bits(&self) -> u32 {
        self.total_bits
    }

    /// The mapping as given.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Bytes of a contiguous, aligned address range that stay in one DRAM row: one channel,
    /// rank, bank and row. These are the line offset and the column bits directly above it;
    /// the first address bit of any other field ends the run. With `gddr5-trax`'s
    /// `row:rank:bank:channel:column:offset` (128 columns of 64 B) it is 2^(6 + 7) = 8192: a
    /// row-aligned 16 KB block is exactly two rows (on two channels). With a channel-interleaved
    /// mapping (`row:column:rank:bank:channel:offset`) it is one line. Data laid out for row
    /// locality (STRaTA's treelets) should be aligned to and sized in multiples of this.
    pub fn row_run_bytes(&self) -> u64 {
        let mut bits = self.line_shift;
        let mut by_shift: Vec<&Slice> = self.slices.iter().collect();
        by_shift.sort_by_key(|s| s.shift);
        for s in by_shift {
            if s.shift != bits || s.field != Field::Column {
                break;
            }
            bits += s.width;
        }
        1u64 << bits
    }

    /// The line-aligned address (offset bits cleared).
    #[inline]
    pub fn line_addr(&self, addr: u64) -> u64 {
        addr >> self.line_shift << self.line_shift
    }

    /// Decode a byte address.
    #[inline]
    pub fn decode(&self, addr: u64) -> Location {
        let mut f = [0u32; 7];
        if let Some(w) = &self.whole_fields {
            for (v, &(shift, mask)) in f.iter_mut().zip(w) {
                *v = (addr >> shift) as u32 & mask;
            }
        } else {
            for s in &self.slices {
                let v = ((addr >> s.shift) & ((1u64 << s.width) - 1)) as u32;
                f[s.field as usize] |= v << s.dest;
            }
        }
        let mut bank = if self.split_groups {
            f[Field::BankGroup as usize] * self.banks_per_group + f[Field::Bank as usize]
        } else {
            f[Field::Bank as usize]
        };
        if self.bank_xor {
            bank ^= f[Field::Row as usize] & self.bank_mask;
        }
        Location {
            channel: f[Field::Channel as usize],
            rank: f[Field::Rank as usize],
            // A power of two (`config::Organisation`).
            bank_group: bank >> self.banks_per_group.trailing_zeros(),
            bank,
            row: f[Field::Row as usize],
            column: f[Field::Column as usize],
        }
    }

    /// Encode a location back into a byte address (inverse of [`AddressMapper::decode`]; used by
    /// tests and synthetic traffic that targets given banks).
    pub fn encode(&self, loc: &Location) -> u64 {
        let mut bank = loc.bank;
        if self.bank_xor {
            bank ^= loc.row & self.bank_mask;
        }
        let mut f = [0u32; 7];
        f[Field::Channel as usize] = loc.channel;
        f[Field::Rank as usize] = loc.rank;
        if self.split_groups {
            f[Field::BankGroup as usize] = bank / self.banks_per_group;
            f[Field::Bank as usize] = bank % self.banks_per_group;
        } else {
            f[Field::Bank as usize] = bank;
        }
        f[Field::Row as usize] = loc.row;
        f[Field::Column as usize] = loc.column;
        let mut addr = 0u64;
        for s in &self.slices {
            let v = u64::from(f[s.field as usize] >> s.dest) & ((1u64 << s.width) - 1);
            addr |= v << s.shift;
        }
        addr
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trax() -> Organisation {
        Organisation::default()
    }

    #[test]
    fn default_mapping_layout() {
        // row:rank:bank:channel:column:offset with 16 ch, 16 banks, 8192 rows, 128 lines/row.
        let m = AddressMapper::new("row:rank:bank:channel:column:offset", false, &trax()).unwrap();
        assert_eq!(m.address_bits(), 6 + 7 + 4 + 4 + 13);
        let l = m.decode(0x40); // line 1
        assert_eq!((l.column, l.channel, l.bank, l.row), (1, 0, 0, 0));
        let l = m.decode(128 * 64); // first line of channel 1
        assert_eq!((l.column, l.channel), (0, 1));
        let l = m.decode(128 * 64 * 16); // bank 1
        assert_eq!((l.channel, l.bank), (0, 1));
        let l = m.decode(1u64 << (6 + 7 + 4 + 4));
        assert_eq!((l.bank, l.row), (0, 1));
        // High bits beyond the capacity are ignored.
        assert_eq!(m.decode(1u64 << 40), m.decode(0));
    }

    #[test]
    fn channel_interleaved_mapping() {
        let m = AddressMapper::new("row:column:rank:bank:channel:offset", false, &trax()).unwrap();
        for line in 0..32u64 {
            let l = m.decode(line * 64);
            assert_eq!(l.channel as u64, line % 16);
            assert_eq!(l.bank as u64, line / 16);
        }
    }

    #[test]
    fn slices_and_roundtrip() {
        let m = AddressMapper::new("row:column(3):bank:channel:column(4):offset", true, &trax())
            .unwrap();
        for addr in [0u64, 0x40, 0x1_2345_6780, 0x3_ffff_ffc0, 0x1357_9bc0] {
            let l = m.decode(addr);
            assert_eq!(m.encode(&l), addr & ((1 << 34) - 1) & !63, "{addr:#x}");
        }
        // Line 16: the low column slice (4 bits) wraps to 0 and the carry lands in the channel.
        let l = m.decode(0x40 * 16);
        assert_eq!((l.column, l.channel), (0, 1));
        // Bit 18 is the lowest bit of the high column slice: column bit 4.
        let l = m.decode(1 << 18);
        assert_eq!((l.column, l.channel, l.bank), (16, 0, 0));
    }

    #[test]
    fn bank_xor_spreads_rows() {
        let m = AddressMapper::new("row:rank:bank:channel:column:offset", true, &trax()).unwrap();
        let row_stride = 1u64 << (6 + 7 + 4 + 4);
        let banks: Vec<u32> = (0..4).map(|r| m.decode(r * row_stride).bank).collect();
        assert_eq!(banks, [0, 1, 2, 3]);
    }

    /// The (channel, rank, bank, row) an address falls in: one DRAM row.
    fn row_of(m: &AddressMapper, addr: u64) -> (u32, u32, u32, u32) {
        let l = m.decode(addr);
        (l.channel, l.rank, l.bank, l.row)
    }

    /// Walk every line of `span` bytes from 0 and check that `row_run_bytes` is exactly the
    /// size of the aligned blocks whose lines share one DRAM row.
    fn check_row_run(m: &AddressMapper, span: u64) -> u64 {
        let run = m.row_run_bytes();
        assert!(run >= 64 && run.is_power_of_two());
        for addr in (0..span).step_by(64) {
            let block = addr / run * run;
            assert_eq!(
                row_of(m, addr),
                row_of(m, block),
                "{}: {addr:#x} leaves the row of its {run}-byte block",
                m.text()
            );
            if addr == block && addr > 0 {
                assert_ne!(
                    row_of(m, addr),
                    row_of(m, addr - 64),
                    "{}: the row continues past {run} bytes at {addr:#x}",
                    m.text()
                );
            }
        }
        run
    }

    #[test]
    fn row_run_matches_the_decoded_rows() {
        // gddr5-trax: 128 lines of 64 B per row, the column field just above the offset.
        let m = AddressMapper::new("row:rank:bank:channel:column:offset", false, &trax()).unwrap();
        assert_eq!(check_row_run(&m, 1 << 20), 8192);
        // A 16 KB block aligned to 8 KB: two rows, on channels 0 and 1.
        let rows: std::collections::BTreeSet<_> =
            (0..16384).step_by(64).map(|a| row_of(&m, a)).collect();
        assert_eq!(rows.len(), 2);
        // The XOR permutation only moves whole rows between banks.
        let m = AddressMapper::new("row:rank:bank:channel:column:offset", true, &trax()).unwrap();
        assert_eq!(check_row_run(&m, 1 << 22), 8192);
        // Channel-interleaved lines: every line is in another row.
        let m = AddressMapper::new("row:column:rank:bank:channel:offset", false, &trax()).unwrap();
        assert_eq!(check_row_run(&m, 1 << 20), 64);
        // Split columns: only the low slice (4 bits) is contiguous.
        let m = AddressMapper::new(
            "row:column(3):bank:channel:column(4):offset",
            false,
            &trax(),
        )
        .unwrap();
        assert_eq!(check_row_run(&m, 1 << 20), 1024);
    }

    #[test]
    fn row_run_of_every_preset() {
        for p in crate::config::PRESETS {
            let c = crate::config::preset_config(p.name).unwrap();
            let m = AddressMapper::new(&c.mapping, c.bank_xor, &c.organisation).unwrap();
            let run = check_row_run(&m, 1 << 21);
            let row_bytes =
                u64::from(c.organisation.columns) * u64::from(c.organisation.bus_width / 8);
            assert!(run <= row_bytes, "{}: run {run} > row {row_bytes}", p.name);
        }
    }

    #[test]
    fn dramsim3_strings() {
        let mut org = trax();
        org.bank_groups = 4;
        org.banks_per_group = 4;
        let m = AddressMapper::new("rochrababgco", false, &org).unwrap();
        let l = m.decode(64);
        assert_eq!(l.column, 1);
        let l = m.decode(128 * 64);
        assert_eq!((l.bank_group, l.bank), (1, 4));
    }

    #[test]
    fn bits_that_do_not_add_up_are_errors() {
        let org = trax();
        for (text, needle) in [
            ("row:bank:channel:column:offset", "rank"), // 1 rank: fine, so check others
            ("row:rank:bank:channel:offset", "column"),
            ("row:rank:bank(3):channel:column:offset", "bank"),
            ("row:rank:bank:channel:column(3):column(3):offset", "column"),
            ("row:rank:bank:channel:column:offset:row", "offset"),
            ("row:rank:bonk:channel:column:offset", "bonk"),
            ("row:rank:bank:channel:column(x):offset", "column(x)"),
            (
                "row:rank:bank:channel:column(4294967295):column(8):offset",
                "4294967295",
            ),
        ] {
            match AddressMapper::new(text, false, &org) {
                Ok(_) if needle == "rank" => {}
                Ok(_) => panic!("{text} accepted"),
                Err(e) => {
                    let e = e.to_string();
                    assert!(e.contains("mapping") && e.contains(needle), "{text}: {e}");
                }
            }
        }
    }
}
