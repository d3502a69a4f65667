//! The blocks of the ray program, recorded from the real kernels (see [`super::asm`]).
//!
//! Each recipe runs the functional kernel on [`Traced`] values chosen to take the path the
//! block stands for (the triangle test's full path, whose prefixes are the early exits; each
//! shading kernel's costliest path, which is what `rtsim_trace::ops::kernel` tabulates), and
//! adds by hand what `rtsim_trace::ops` counts by inspection (loads, stores, integer, bitwise
//! and branch instructions), with the registers they read and write.

use super::asm::{
    self, Traced, bitwise, branch, conv, imm, int_add, int_mul, last_compare, load, load_value,
    local_load, local_store, mark, output, record, store,
};
use super::{BlockInfo, Program, Seg};
use crate::isa::{INST_BYTES, Inst, Reg, regs};
use rtsim_core::{Real, Vec3};
use rtsim_trace::kernels::triangle::{moller_trumbore_exit, mt_exit};
use rtsim_trace::kernels::{box_entry, inverse_direction};
use rtsim_trace::workload::{KERNELS, Kernel};
use rtsim_trace::{sampling, shade};

fn reg3(r: [Reg; 3], v: Vec3) -> Vec3<Traced> {
    Vec3::xyz(
        Traced::reg(r[0], v.x),
        Traced::reg(r[1], v.y),
        Traced::reg(r[2], v.z),
    )
}

fn state3(v: Vec3) -> Vec3<Traced> {
    Vec3::xyz(Traced::state(v.x), Traced::state(v.y), Traced::state(v.z))
}

fn imm3(v: Vec3) -> Vec3<Traced> {
    Vec3::from_f32(v)
}

fn out3(v: Vec3<Traced>, r: [Reg; 3]) {
    output(v.x, r[0]);
    output(v.y, r[1]);
    output(v.z, r[2]);
}

/// Three consecutive words of record base `base` from word `first`, carrying `v`.
fn load3(base: u8, first: u8, addr: Traced, v: Vec3) -> Vec3<Traced> {
    Vec3::xyz(
        load_value(base, first, addr, v.x),
        load_value(base, first + 1, addr, v.y),
        load_value(base, first + 2, addr, v.z),
    )
}

/// One uniform random number (`Pcg32::next_f32`, `rtsim_trace::ops::RANDOM`): the LCG step
/// (multiply, add) on the old state, XSH-RR on the old state (shift, xor, shift, the rotation
/// amount, the rotate), the top 24 bits (shift), conversion and scaling. Returns the number and
/// the new state.
fn random(old: Traced) -> (Traced, Traced) {
    let new = int_add(int_mul(old, imm()), imm());
    let a = bitwise(old, imm());
    let b = bitwise(a, old);
    let c = bitwise(b, imm());
    let rot = bitwise(old, imm());
    let o = bitwise(c, rot);
    let top = bitwise(o, imm());
    let u = conv(top) * Traced::from_f32(1.0 / 16_777_216.0);
    (u, new)
}

/// The box test of one node record (base `base`, address from `addr`): its 6 loads, then
/// `box_entry` with values that hit, returning the entry distance (the comparison's result is
/// [`last_compare`]).
fn box_test(base: u8, addr: Traced, lo: f32) -> Traced {
    let min = load3(base, 0, addr, Vec3::splat(lo));
    let max = load3(base, 3, addr, Vec3::splat(lo + 1.0));
    box_entry(
        reg3(regs::ORG, Vec3::ZERO),
        reg3(regs::INV, Vec3::ONE),
        min,
        max,
        Traced::reg(regs::TMIN, 0.0),
        Traced::reg(regs::THIT, f32::INFINITY),
    )
    .expect("the recording box is hit")
}

/// Every Möller–Trumbore exit, `HIT` first (`mt_exit::ALL`).
pub const ALL_EXITS: [u8; 8] = mt_exit::ALL;

/// Comparisons evaluated up to each exit (the test's early returns, in code order).
fn compares_to(exit: u8) -> usize {
    match exit {
        mt_exit::PARALLEL => 1,
        mt_exit::U_LOW => 2,
        mt_exit::U_HIGH => 3,
        mt_exit::V_LOW => 4,
        mt_exit::UV_HIGH => 5,
        mt_exit::T_LOW => 6,
        _ => 7,
    }
}

struct Layout {
    insts: Vec<Inst>,
    blocks: Vec<BlockInfo>,
}

impl Layout {
    /// Append a compiled block; returns its segment and the instruction counts (within the block) at its
    /// marks.
    fn add(&mut self, name: &'static str, about: &'static str, tape: asm::Tape) -> (Seg, Vec<u32>) {
        self.add_with(name, about, tape, &[])
    }

    /// A shading block: the traversal registers are dead and serve as temporaries too.
    fn add_shading(&mut self, name: &'static str, about: &'static str, tape: asm::Tape) -> Seg {
        self.add_with(name, about, tape, &SHADING_TEMPS).0
    }

    fn add_with(
        &mut self,
        name: &'static str,
        about: &'static str,
        tape: asm::Tape,
        extra: &[Reg],
    ) -> (Seg, Vec<u32>) {
        let c = tape.compile_with(name, extra);
        let start = self.insts.len() as u32;
        for (k, mut i) in c.insts.into_iter().enumerate() {
            i.pc = (start + k as u32) * INST_BYTES;
            self.insts.push(i);
        }
        let seg = Seg {
            start,
            len: self.insts.len() as u32 - start,
        };
        self.blocks.push(BlockInfo {
            name,
            about,
            seg,
            exits: Vec::new(),
        });
        (seg, c.marks.iter().map(|&m| m as u32).collect())
    }

    fn exits(&mut self, exits: Vec<(String, u32)>) {
        self.blocks.last_mut().expect("a block was added").exits = exits;
    }
}

/// Registers free while a pixel is shaded: the traversal state (the next ray's setup rewrites
/// `thit` and `tmin`; `slot`, `org` and `dir` stay live).
const SHADING_TEMPS: [Reg; 10] = [
    regs::INV[0],
    regs::INV[1],
    regs::INV[2],
    regs::TMIN,
    regs::THIT,
    regs::NODE,
    regs::SP,
    regs::CHILD,
    regs::END,
    regs::TNEAR,
];

const LIGHT: Vec3 = Vec3::new(0.0, 5.0, 0.0);

pub(super) fn build() -> Program {
    let mut l = Layout {
        insts: Vec::new(),
        blocks: Vec::new(),
    };

    // --- Per-pixel and per-ray control ------------------------------------------------------
    let (next_pixel, _) = l.add(
        "next_pixel",
        "`atominc` on the global pixel counter, the test against the pixel count and its \
         branch, then x and y from the index (a multiply by the reciprocal of the width, a \
         shift, a multiply and a subtract). Not in `rtsim_trace::ops` (the workload's state \
         machine starts at a pixel index); by inspection of a TRaX main loop.",
        record(false, || {
            let p = asm::atomic();
            branch(int_add(p, imm()));
            let y = bitwise(int_mul(p, imm()), imm());
            let _x = int_add(p, int_mul(y, imm()));
        }),
    );
    let (ray_setup, _) = l.add(
        "ray_setup",
        "The slab test's per-ray setup (`kernels::inverse_direction`, `ops::INVERSE_DIRECTION`): \
         three reciprocals of the direction, each checked for finiteness and branched on.",
        record(true, || {
            let inv = inverse_direction(reg3(regs::DIR, Vec3::new(0.3, -0.5, 0.8)));
            out3(inv, regs::INV);
        }),
    );
    let (inv_fixup, _) = l.add(
        "inv_fixup",
        "`copysign(MAX, d)` replacing an infinite reciprocal, once per zero direction component \
         (`ops::INVERSE_DIRECTION_FIXUP`).",
        record(false, || {
            let m = Traced::from_f32(f32::MAX).copysign(Traced::reg(regs::DIR[0], 0.0));
            output(m, regs::INV[0]);
        }),
    );

    // --- Traversal steps (`ops::step` for `stack`) --------------------------------------------
    let (root_box, _) = l.add(
        "root_box",
        "`Step::RootBox`: the root's box (6 loads of node 0) against the ray, and the branch on \
         the result (`ops::BOX_TEST` + 1 branch).",
        record(false, || {
            box_test(0, imm(), -1.0);
            branch(last_compare());
        }),
    );
    let (node, _) = l.add(
        "node",
        "`Step::Node`: load the node's child index and count (words 6 and 7), test for a leaf \
         (integer compare) and branch.",
        record(false, || {
            let node = Traced::reg(regs::NODE, 0.0);
            output(load(0, 6, node), regs::CHILD);
            let count = load(0, 7, node);
            output(count, regs::END);
            branch(int_add(count, imm()));
        }),
    );
    let (pair, pair_marks) = l.add(
        "child_pair",
        "`Step::ChildPair`: both children's boxes (6 loads each, addressed from the child \
         index) tested, the right child's index (`left + 1`), a branch on each hit; when both \
         are hit, the order comparison of the entry distances and its branch (the last two \
         instructions).",
        record(false, || {
            let child = Traced::reg(regs::CHILD, 0.0);
            let near_a = box_test(0, child, 1.0);
            let hit_a = last_compare();
            let near_b = box_test(1, child, 2.0);
            let hit_b = last_compare();
            output(near_b, regs::TNEAR);
            output(int_add(child, imm()), regs::NODE);
            branch(hit_a);
            branch(hit_b);
            mark();
            let _ = near_a <= near_b;
            branch(last_compare());
        }),
    );
    l.exits(vec![
        ("one or no box hit".into(), pair_marks[0]),
        ("both hit".into(), pair.len),
    ]);
    let (push, _) = l.add(
        "push",
        "`Step::Push`: store the deferred child and its entry distance to the stack entry in \
         local memory, increment the stack pointer.",
        record(false, || {
            let sp = Traced::reg(regs::SP, 0.0);
            local_store(0, sp, Traced::reg(regs::NODE, 0.0));
            local_store(1, sp, Traced::reg(regs::TNEAR, 0.0));
            output(int_add(sp, imm()), regs::SP);
        }),
    );
    let (pop, _) = l.add(
        "pop",
        "`Step::Pop`: the empty test (integer compare, branch), decrement, load the entry's node \
         and entry distance from local memory, the cull comparison against the closest hit and \
         its branch.",
        record(false, || {
            let sp = Traced::reg(regs::SP, 0.0);
            branch(int_add(sp, imm()));
            let sp = int_add(sp, imm());
            output(sp, regs::SP);
            output(local_load(0, sp), regs::NODE);
            let t = local_load(1, sp);
            let _ = t >= Traced::reg(regs::THIT, 1.0);
            branch(last_compare());
        }),
    );
    let (tri, tri_marks) = l.add(
        "triangle",
        "`Step::Triangle` with Möller–Trumbore (`ops::moller_trumbore`): the 9 vertex words, \
         the two edges, then the test; every comparison is followed by its branch, and each \
         exit runs a prefix of the block (see the exits).",
        record(true, || {
            let slot = Traced::reg(regs::CHILD, 0.0);
            let v0 = load3(0, 0, slot, Vec3::ZERO);
            let v1 = load3(0, 3, slot, Vec3::new(1.0, 0.0, 0.0));
            let e1 = v1 - v0;
            let v2 = load3(0, 6, slot, Vec3::new(0.0, 1.0, 0.0));
            let e2 = v2 - v0;
            let hit = moller_trumbore_exit(
                v0,
                e1,
                e2,
                reg3(regs::ORG, Vec3::new(0.2, 0.2, 1.0)),
                reg3(regs::DIR, Vec3::new(0.0, 0.0, -1.0)),
                Traced::reg(regs::TMIN, 0.0),
                Traced::reg(regs::THIT, f32::INFINITY),
            );
            assert!(hit.is_ok(), "the recording ray hits the recording triangle");
        }),
    );
    assert_eq!(
        tri_marks.len(),
        7,
        "Möller–Trumbore evaluates 7 comparisons on a hit"
    );
    let mut tri_exit = [0u32; 8];
    for e in ALL_EXITS {
        tri_exit[e as usize] = tri_marks[compares_to(e) - 1];
    }
    let exit_names = [
        "hit",
        "parallel",
        "u < 0",
        "u > 1",
        "v < 0",
        "u + v > 1",
        "t ≤ tmin",
        "t ≥ tmax",
    ];
    l.exits(
        ALL_EXITS
            .iter()
            .map(|&e| (exit_names[e as usize].to_string(), tri_exit[e as usize]))
            .collect(),
    );
    let (tri_tail, _) = l.add(
        "triangle_tail",
        "After every triangle test: the slot increment, the loop test against the leaf's end \
         and its branch (the `int 2 + branch 1` of `ops::step`'s `Triangle` row).",
        record(false, || {
            let s = int_add(Traced::reg(regs::CHILD, 0.0), imm());
            output(s, regs::CHILD);
            branch(int_add(s, Traced::reg(regs::END, 0.0)));
        }),
    );

    // --- Shading (`ops::kernel`, `ops::shading`) ----------------------------------------------
    let mut kernels = [Seg::default(); KERNELS];
    let basis = (
        imm3(Vec3::new(1.0, 0.0, 0.0)),
        imm3(Vec3::new(0.0, 1.0, 0.0)),
        imm3(Vec3::new(0.0, 0.0, -1.0)),
    );
    kernels[Kernel::CameraRay as usize] = l.add_shading(
        "camera_ray",
        "`Kernel::CameraRay`: the pixel position converted and offset by the jitter, the \
             direction through it from the camera basis (per-frame immediates), normalised; \
             written to the direction registers.",
        record(true, || {
            let x = Traced::from_u32(3) + Traced::state(0.5);
            let y = Traced::from_u32(5) + Traced::state(0.5);
            let d = shade::camera_ray_direction(
                &basis,
                Traced::from_f32(0.4),
                Traced::from_f32(1.3),
                x,
                y,
                Traced::from_f32(64.0),
                Traced::from_f32(48.0),
            );
            out3(d, regs::DIR);
        }),
    );
    kernels[Kernel::Jitter as usize] = l.add_shading(
        "jitter",
        "`Kernel::Jitter`: two random numbers (`ops::RANDOM` each) from the pixel's PCG32 \
             state.",
        record(false, || {
            let (_, s) = random(Traced::state(0.0));
            let _ = random(s);
        }),
    );
    kernels[Kernel::Surface as usize] = l.add_shading(
        "surface",
        "Reads the hit triangle's 9 vertex words (`ops::TRIANGLE_READ_WORDS`, addressed from \
             the hit slot), then `Kernel::Surface` on its costliest path: the normal (edges, \
             cross product, normalisation), flipped to face the ray (3 sign flips), the \
             interpolated point and its offset.",
        record(true, || {
            let slot = Traced::reg(regs::SLOT, 0.0);
            let v0 = load3(0, 0, slot, Vec3::ZERO);
            let v1 = load3(0, 3, slot, Vec3::new(1.0, 0.0, 0.0));
            let v2 = load3(0, 6, slot, Vec3::new(0.0, 1.0, 0.0));
            let _ = shade::surface(
                &[v0, v1, v2],
                Traced::state(0.2),
                Traced::state(0.3),
                reg3(regs::DIR, Vec3::new(0.0, 0.0, 1.0)),
                Traced::from_f32(1e-4),
            );
        }),
    );
    kernels[Kernel::Headlight as usize] = l.add_shading(
        "headlight",
        "`Kernel::Headlight`: albedo scaled by the cosine to the viewer, plus emission.",
        record(true, || {
            let _ = shade::headlight(
                state3(Vec3::ONE),
                state3(Vec3::ZERO),
                state3(Vec3::new(0.0, 0.0, 1.0)),
                reg3(regs::DIR, Vec3::new(0.0, 0.0, -1.0)),
            );
        }),
    );
    kernels[Kernel::DirectLight as usize] = l.add_shading(
        "direct_light",
        "`Kernel::DirectLight`: the unshadowed Lambertian response to the point light \
             (position and intensity are per-frame immediates).",
        record(true, || {
            let _ = shade::direct_unshadowed(
                imm3(LIGHT),
                imm3(Vec3::ONE),
                state3(Vec3::ZERO),
                state3(Vec3::new(0.0, 1.0, 0.0)),
                state3(Vec3::splat(0.5)),
            );
        }),
    );
    kernels[Kernel::ShadowRay as usize] = l.add_shading(
        "shadow_ray",
        "`Kernel::ShadowRay`: the direction to the light (t = 1 at the light) into the \
             direction registers.",
        record(true, || {
            out3(
                shade::shadow_direction(imm3(LIGHT), state3(Vec3::splat(0.1))),
                regs::DIR,
            )
        }),
    );
    kernels[Kernel::CosineBounce as usize] = l.add_shading(
        "cosine_bounce",
        "`Kernel::CosineBounce` on its costliest path: two random numbers, the concentric \
             map's second branch (a divide, software cosine and sine), the lift to the \
             hemisphere, the basis around the normal, the rotation and normalisation.",
        record(true, || {
            let (u, s) = random(Traced::state(0.0));
            let (v, _) = random(s);
            let d = shade::cosine_bounce(
                state3(Vec3::new(0.0, 0.6, 0.8)),
                u.with_value(0.55),
                v.with_value(0.95),
            );
            out3(d, regs::DIR);
        }),
    );
    kernels[Kernel::HaltonRay as usize] = l.add_shading(
        "halton_ray",
        "`Kernel::HaltonRay`: the Halton point (base 2: bit reversal, shift, conversion, \
             scale; base 3: four digits of a divide and remainder by 3 by multiplication, a \
             conversion, two multiplies, an add and the loop branch, the loop exit, a \
             conversion and a min; both coordinates rotated and wrapped), then the cosine warp \
             of a bounce.",
        record(true, || {
            let i = Traced::state(0.0);
            let r = bitwise(bitwise(i, imm()), imm());
            let u = conv(r) * Traced::from_f32(1.0 / 16_777_216.0);
            let (mut n, mut acc, mut scale) = (i, imm(), Traced::from_f32(1.0 / 3.0));
            for _ in 0..4 {
                let q = int_mul(n, imm());
                let digit = int_add(n, int_mul(q, imm()));
                acc = acc + conv(digit) * scale;
                scale = scale * Traced::from_f32(1.0 / 3.0);
                branch(q);
                n = q;
            }
            branch(n);
            let v = conv(acc).min(Traced::from_f32(1.0));
            let wrap = |x: Traced| {
                let s = x + Traced::state(0.25);
                let _ = s >= Traced::from_f32(1.0);
                s - Traced::from_f32(1.0)
            };
            let (u, v) = (wrap(u), wrap(v));
            let d = sampling::cosine_hemisphere(
                state3(Vec3::new(0.0, 0.6, 0.8)),
                u.with_value(0.55),
                v.with_value(0.95),
            );
            out3(d, regs::DIR);
        }),
    );
    kernels[Kernel::Reflect as usize] = l.add_shading(
        "reflect",
        "`Kernel::Reflect`: the mirror direction into the direction registers.",
        record(true, || {
            out3(
                shade::reflect(
                    reg3(regs::DIR, Vec3::new(0.0, 0.0, -1.0)),
                    state3(Vec3::new(0.0, 0.0, 1.0)),
                ),
                regs::DIR,
            )
        }),
    );
    kernels[Kernel::Accumulate as usize] = l.add_shading(
        "accumulate",
        "`Kernel::Accumulate`: `sum += x` on a colour.",
        record(true, || {
            let mut a = state3(Vec3::ONE);
            a += state3(Vec3::ONE);
        }),
    );
    kernels[Kernel::Weighted as usize] = l.add_shading(
        "weighted",
        "`Kernel::Weighted`: `acc += w ⊙ x`.",
        record(true, || {
            let mut a = state3(Vec3::ONE);
            a += state3(Vec3::ONE).mul_elem(state3(Vec3::ONE));
        }),
    );
    kernels[Kernel::Attenuate as usize] = l.add_shading(
        "attenuate",
        "`Kernel::Attenuate`: `t = t ⊙ a`.",
        record(true, || {
            let _ = state3(Vec3::ONE).mul_elem(state3(Vec3::ONE));
        }),
    );
    kernels[Kernel::Finish as usize] = l.add_shading(
        "finish",
        "`Kernel::Finish`: the sample count converted, one reciprocal and three multiplies.",
        record(true, || {
            let _ = state3(Vec3::ONE) / Traced::from_u32(4);
        }),
    );
    let material_read = l.add_shading(
        "material_read",
        "The hit material's albedo and emission (`ops::MATERIAL_READ_WORDS`, 6 loads; the \
         material id comes with the path state).",
        record(false, || {
            for w in 0..6 {
                let _ = load(0, w, Traced::state(0.0));
            }
        }),
    );
    let framebuffer_write = l.add_shading(
        "framebuffer_write",
        "The pixel's colour to the framebuffer (`ops::FRAMEBUFFER_WRITE_WORDS`, 3 stores).",
        record(false, || {
            for w in 0..3 {
                store(0, w, Traced::state(0.0), Traced::state(0.0));
            }
        }),
    );

    let pair_one = pair_marks[0];
    Program {
        insts: l.insts,
        blocks: l.blocks,
        ray_setup,
        inv_fixup,
        root_box,
        node,
        pair,
        pair_one,
        push,
        pop,
        tri,
        tri_exit,
        tri_tail,
        kernels,
        material_read,
        framebuffer_write,
        next_pixel,
    }
}
