//! The tables against instrumented runs of the real kernels.

use super::*;
use crate::kernels::triangle::{
    Wald, moller_trumbore_exit, mt_edges, plucker_exit as plucker_test, wald_exit as wald_test,
};
use crate::kernels::{HIT, box_entry, inverse_direction};
use crate::shade;
use rtsim_core::{Pcg32, Vec3};
use std::collections::BTreeMap;

type V = Vec3<Counted>;

fn cv(v: Vec3) -> V {
    V::from_f32(v)
}

fn rand_v(g: &mut Pcg32, s: f32) -> Vec3 {
    Vec3::new(g.next_f32() - 0.5, g.next_f32() - 0.5, g.next_f32() - 0.5) * s
}

/// Random triangles and rays aimed near them, plus degenerate and parallel cases, so every
/// exit occurs.
fn cases(n: usize, seed: u64) -> Vec<([Vec3; 3], Vec3, Vec3, f32, f32)> {
    let mut g = Pcg32::new(seed, 1);
    (0..n)
        .map(|i| {
            let c = rand_v(&mut g, 4.0);
            let mut tri = [
                c + rand_v(&mut g, 2.0),
                c + rand_v(&mut g, 2.0),
                c + rand_v(&mut g, 2.0),
            ];
            if i % 97 == 0 {
                tri[2] = tri[1]; // degenerate
            }
            let o = rand_v(&mut g, 10.0);
            let target = c + rand_v(&mut g, 2.5);
            let mut d = target - o;
            if i % 89 == 0 {
                // Parallel to the plane.
                let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                d = n.cross(Vec3::new(0.3, 0.7, -0.2));
            }
            let tmax = match i % 5 {
                0 => g.next_f32() * 0.9,
                _ => f32::INFINITY,
            };
            let tmin = if i % 7 == 0 { 0.8 } else { 0.0 };
            (tri, o, d, tmin, tmax)
        })
        .collect()
}

/// Measured mixes by exit; panics if one exit costs two different amounts.
fn by_exit(f: impl Fn(&([Vec3; 3], Vec3, Vec3, f32, f32)) -> (u8, OpMix)) -> BTreeMap<u8, OpMix> {
    let mut seen = BTreeMap::new();
    for c in cases(20_000, 7) {
        let (exit, m) = f(&c);
        if let Some(prev) = seen.insert(exit, m) {
            assert_eq!(prev, m, "exit {exit} costs two different amounts");
        }
    }
    seen
}

fn check(
    name: &str,
    all: &[u8],
    measured: BTreeMap<u8, OpMix>,
    table: impl Fn(u8) -> OpMix,
    extra: OpMix,
) {
    for &e in all {
        let m = measured
            .get(&e)
            .unwrap_or_else(|| panic!("{name}: exit {e} never occurred"));
        assert_eq!(
            (*m + extra).float_part(),
            table(e).float_part(),
            "{name} exit {e}: measured {m:?}"
        );
    }
}

#[test]
fn moller_trumbore_table_matches_the_kernel() {
    let measured = by_exit(|&(tri, o, d, tmin, tmax)| {
        let (r, m) = count(|| {
            let rec = mt_edges(&tri.map(cv));
            moller_trumbore_exit(
                rec[0],
                rec[1],
                rec[2],
                cv(o),
                cv(d),
                Counted(tmin),
                Counted(tmax),
            )
        });
        (r.err().unwrap_or(HIT), m)
    });
    check("MT", &mt_exit::ALL, measured, moller_trumbore, OpMix::ZERO);
}

#[test]
fn plucker_table_matches_the_kernel() {
    let measured = by_exit(|&(tri, o, d, tmin, tmax)| {
        let (r, m) =
            count(|| plucker_test(&tri.map(cv), cv(o), cv(d), Counted(tmin), Counted(tmax)));
        (r.err().unwrap_or(HIT), m)
    });
    // T_ROUNDED needs a rounding accident at the interval's end; it costs what a hit costs
    // before the barycentrics.
    let exits: Vec<u8> = plucker_exit::ALL
        .into_iter()
        .filter(|&e| e != plucker_exit::T_ROUNDED)
        .collect();
    check("Plücker", &exits, measured, plucker, OpMix::ZERO);
    let hit = plucker(HIT);
    let rounded = plucker(plucker_exit::T_ROUNDED);
    assert_eq!(rounded.fmul + 2, hit.fmul);
    assert_eq!(rounded.fadd, hit.fadd);
}

#[test]
fn wald_table_matches_the_kernel() {
    let measured = by_exit(|&(tri, o, d, tmin, tmax)| {
        let w = Wald::record(&tri);
        let f = [
            w.n_u, w.n_v, w.n_d, w.b_nu, w.b_nv, w.b_d, w.c_nu, w.c_nv, w.c_d,
        ]
        .map(Counted);
        let (r, m) = count(|| wald_test(&f, w.k, cv(o), cv(d), Counted(tmin), Counted(tmax)));
        (r.err().unwrap_or(HIT), m)
    });
    check("Wald", &wald_exit::ALL, measured, wald, OpMix::ZERO);
}

#[test]
fn box_test_and_ray_setup_tables_match() {
    let mut g = Pcg32::new(3, 3);
    for _ in 0..5000 {
        let (o, d) = (rand_v(&mut g, 10.0), rand_v(&mut g, 1.0));
        let (inv, m) = count(|| inverse_direction(cv(d)));
        assert_eq!(m.float_part(), INVERSE_DIRECTION.float_part());
        let (lo, hi) = (rand_v(&mut g, 4.0), rand_v(&mut g, 4.0));
        let (_, m) = count(|| {
            box_entry(
                cv(o),
                inv,
                cv(lo.min(hi)),
                cv(lo.max(hi)),
                Counted(0.0),
                Counted(f32::INFINITY),
            )
        });
        assert_eq!(m.float_part(), BOX_TEST.float_part());
    }
    // A zero direction component: one copysign more.
    let (_, m) = count(|| inverse_direction(cv(Vec3::new(0.0, 1.0, 2.0))));
    assert_eq!(
        m.float_part(),
        (INVERSE_DIRECTION + INVERSE_DIRECTION_FIXUP).float_part()
    );
}

/// A shading kernel's table is its costliest path: every run costs at most the table, and
/// some run costs exactly it.
fn check_worst(name: &str, table: OpMix, runs: impl Iterator<Item = OpMix>) {
    let t = table.float_part();
    let mut reached = false;
    for m in runs {
        let m = m.float_part();
        let le = m.fadd <= t.fadd
            && m.fmul <= t.fmul
            && m.fminmax <= t.fminmax
            && m.fcmp <= t.fcmp
            && m.fdiv <= t.fdiv
            && m.fsqrt <= t.fsqrt
            && m.ftrig <= t.ftrig
            && m.conv <= t.conv
            && m.bitwise <= t.bitwise;
        assert!(le, "{name}: a run costs {m:?}, more than the table {t:?}");
        reached |= m == t;
    }
    assert!(reached, "{name}: no run reached the table {t:?}");
}

#[test]
fn shading_tables_are_the_kernels_costliest_paths() {
    let mut g = Pcg32::new(11, 2);
    let n = 4000;
    let mut inputs: Vec<(Vec3, Vec3, Vec3, [Vec3; 3])> = (0..n)
        .map(|_| {
            let tri = [
                rand_v(&mut g, 3.0),
                rand_v(&mut g, 3.0),
                rand_v(&mut g, 3.0),
            ];
            (
                rand_v(&mut g, 2.0).normalized(),
                rand_v(&mut g, 5.0),
                rand_v(&mut g, 1.0),
                tri,
            )
        })
        .collect();
    inputs.push((
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::ZERO,
        Vec3::ONE,
        [Vec3::ZERO; 3],
    ));
    let uv = |g: &mut Pcg32| (g.next_f32() * 0.5, g.next_f32() * 0.5);
    check_worst(
        "Surface",
        kernel(Kernel::Surface),
        inputs.iter().map(|(_, _, d, tri)| {
            let (u, v) = uv(&mut g);
            count(|| shade::surface(&tri.map(cv), Counted(u), Counted(v), cv(*d), Counted(1e-4))).1
        }),
    );
    check_worst(
        "DirectLight",
        kernel(Kernel::DirectLight),
        inputs.iter().map(|(n, p, a, _)| {
            count(|| {
                shade::direct_unshadowed(
                    cv(Vec3::splat(3.0)),
                    cv(Vec3::ONE),
                    cv(*p),
                    cv(*n),
                    cv(a.abs()),
                )
            })
            .1
        }),
    );
    check_worst(
        "Headlight",
        kernel(Kernel::Headlight),
        inputs.iter().map(|(n, _, d, _)| {
            count(|| shade::headlight(cv(Vec3::ONE), cv(Vec3::ZERO), cv(*n), cv(*d))).1
        }),
    );
    check_worst(
        "Reflect",
        kernel(Kernel::Reflect),
        inputs
            .iter()
            .map(|(n, _, d, _)| count(|| shade::reflect(cv(*d), cv(*n))).1),
    );
    check_worst(
        "ShadowRay",
        kernel(Kernel::ShadowRay),
        inputs
            .iter()
            .map(|(_, p, _, _)| count(|| shade::shadow_direction(cv(Vec3::splat(2.0)), cv(*p))).1),
    );
    let basis = (
        cv(Vec3::new(1.0, 0.0, 0.0)),
        cv(Vec3::new(0.0, 1.0, 0.0)),
        cv(Vec3::new(0.0, 0.0, -1.0)),
    );
    check_worst(
        "CameraRay",
        kernel(Kernel::CameraRay),
        (0..n as u32).map(|i| {
            let (jx, jy) = uv(&mut g);
            count(|| {
                let x = Counted::from_u32(i % 64) + Counted(jx);
                let y = Counted::from_u32(i / 64) + Counted(jy);
                shade::camera_ray_direction(
                    &basis,
                    Counted(0.4),
                    Counted(1.3),
                    x,
                    y,
                    Counted(64.0),
                    Counted(48.0),
                )
            })
            .1
        }),
    );
    check_worst(
        "CosineBounce",
        kernel(Kernel::CosineBounce),
        inputs.iter().map(|(n, _, _, _)| {
            let (u, v) = (g.next_f32(), g.next_f32());
            count(|| shade::cosine_bounce(cv(*n), Counted(u), Counted(v))).1 + RANDOM.times(2)
        }),
    );
    let simple = [
        (Kernel::Accumulate, {
            let (mut a, b) = (cv(Vec3::ONE), cv(Vec3::ONE));
            count(|| a += b).1
        }),
        (Kernel::Weighted, {
            let (mut a, w, x) = (cv(Vec3::ONE), cv(Vec3::ONE), cv(Vec3::ONE));
            count(|| a += w.mul_elem(x)).1
        }),
        (Kernel::Attenuate, {
            let (t, a) = (cv(Vec3::ONE), cv(Vec3::ONE));
            count(|| t.mul_elem(a)).1
        }),
        (Kernel::Finish, {
            let s = cv(Vec3::ONE);
            count(|| s / Counted::from_u32(4)).1
        }),
    ];
    for (k, m) in simple {
        assert_eq!(m.float_part(), kernel(k).float_part(), "{k:?}");
    }
    inputs.clear();
}

/// The step table agrees with the counters: local-memory words, box and triangle tests.
#[test]
fn step_mixes_account_for_the_counters() {
    use crate::config::{TraceConfig, TraversalOrder};
    use crate::counters::RayCounters;
    use crate::testutil::{median_bvh, random_rays, random_soup};
    use crate::tracer::Tracer;
    let tris = random_soup(1500, 5, 1.5);
    let rays = random_rays(500, 6);
    for traversal in [Traversal::Stack, Traversal::BitStack, Traversal::ShortStack] {
        for test in [
            TriangleTest::MollerTrumbore,
            TriangleTest::Plucker,
            TriangleTest::Wald,
        ] {
            let cfg = TraceConfig {
                traversal,
                triangle_test: test,
                order: TraversalOrder::NearestFirst,
                short_stack_entries: 3,
                ..TraceConfig::default()
            };
            let t = Tracer::new(&tris, median_bvh(&tris, 3), &cfg).unwrap();
            for ray in &rays {
                let mut c = RayCounters::default();
                let mut st = t.start(ray, crate::step::Query::Closest);
                let mut total = OpMix::ZERO;
                loop {
                    let s = t.step(&mut st, &mut c);
                    total += step(traversal, test, &s);
                    if s.is_done() {
                        break;
                    }
                }
                let local = if traversal == Traversal::BitStack {
                    0
                } else {
                    2 * (c.stack_pushes + c.stack_pops)
                };
                assert_eq!(total.local, local);
                // Box tests' subtractions: 6 each; the rest comes from triangle tests.
                assert!(total.fminmax == 12 * c.box_tests, "{traversal:?}");
            }
        }
    }
}
