//! Print the fused blocks' instruction fetches and register-file accesses beside the TRaX
//! program's blocks they replace:
//!
//! ```text
//! cargo run -p rtsim-strata --example pipeline_counts
//! ```

use rtsim_strata::pipeline::{self, FusedBlock};
use rtsim_trace::kernels::HIT;
use rtsim_trace::kernels::triangle::plucker_exit;
use rtsim_trax::{Program, Seg};

fn base(p: &Program, s: Seg) -> (u32, u32, u32) {
    p.seg(s).iter().fold((s.len, 0, 0), |(n, r, w), i| {
        let (a, b) = i.register_accesses();
        (n, r + a, w + b)
    })
}

fn row(name: &str, (n, r, w): (u32, u32, u32)) {
    println!("| {name} | {n} | {r} | {w} | {} |", r + w);
}

fn fused(f: &FusedBlock) -> (u32, u32, u32) {
    let (r, w) = f.register_accesses();
    (f.fetches(), r, w)
}

fn main() {
    let p = Program::new();
    println!("| block | fetches | RF reads | RF writes | RF accesses |");
    println!("|---|---:|---:|---:|---:|");
    row("TRaX `child_pair`, both hit", base(&p, p.pair));
    row(
        "TRaX `child_pair`, one or none",
        base(&p, p.pair.prefix(p.pair_one)),
    );
    row(
        "fused child pair, both hit",
        fused(&pipeline::child_pair(true)),
    );
    row(
        "fused child pair, one or none",
        fused(&pipeline::child_pair(false)),
    );
    row("TRaX `root_box`", base(&p, p.root_box));
    row("fused root box", fused(&pipeline::root_box()));
    row(
        "fused sibling re-test (`bit-stack`)",
        fused(&pipeline::sibling_retest()),
    );
    row("TRaX `triangle` (Möller–Trumbore), hit", base(&p, p.tri));
    row(
        "fused Plücker, miss",
        fused(&pipeline::triangle(plucker_exit::OUTSIDE)),
    );
    row("fused Plücker, hit", fused(&pipeline::triangle(HIT)));
}
