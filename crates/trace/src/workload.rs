//! Workloads: how a pixel's rays are generated and shaded.
//!
//! Every pixel has its own random stream derived from (seed, pixel index), so a pixel's rays
//! do not depend on which thread traces it or in what order: renders are bit-identical for any
//! thread count. All rays go through the reference [`Tracer`] and are counted by kind.
//!
//! | kind | rays per pixel (per sample) | source |
//! |---|---|---|
//! | `primary` | 1 closest-hit camera ray | SGRT Table 4 |
//! | `ao` | 1 primary + `spp` any-hit cosine rays of length `ao_radius` (Halton) | SGRT Tables 4–5 |
//! | `diffuse` | 1 primary + `spp` closest-hit cosine rays (Halton) | SGRT Tables 4–5 |
//! | `path` | per sample: up to `max_depth` closest-hit segments, each hit with one shadow ray to the point light; cosine bounces | STRaTA §5 |
//! | `specular` | 1 primary + up to `specular_bounces` mirror rays | SGRT Table 3 |

use crate::config::WorkloadKind;
use crate::counters::{CounterTotals, RayCounters};
use crate::sampling::{cosine_hemisphere, halton2};
use crate::tracer::{Hit, Tracer};
use rtsim_core::rng::stream_seed;
use rtsim_core::{Pcg32, Ray, Vec3};
use rtsim_scene::Scene;
use serde::{Deserialize, Serialize};
use std::f32::consts::FRAC_1_PI;
use std::ops::AddAssign;

/// Counters per ray kind for a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameStats {
    pub primary: CounterTotals,
    /// Path tracing: shadow rays to the point light.
    pub shadow: CounterTotals,
    /// Path tracing: cosine-weighted bounce rays.
    pub bounce: CounterTotals,
    pub ao: CounterTotals,
    pub diffuse: CounterTotals,
    pub specular: CounterTotals,
}

impl FrameStats {
    /// All kinds together.
    pub fn total(&self) -> CounterTotals {
        let mut t = self.primary;
        for k in [
            self.shadow,
            self.bounce,
            self.ao,
            self.diffuse,
            self.specular,
        ] {
            t += k;
        }
        t
    }

    /// Path tracing: ray segments (camera rays, bounces and shadow rays; STRaTA's
    /// "10.5 M ray segments" for 1024×1024).
    pub fn path_segments(&self) -> u64 {
        self.primary.rays + self.bounce.rays + self.shadow.rays
    }

    /// (kind name, totals) for every kind that traced rays, in a fixed order.
    pub fn by_kind(&self) -> Vec<(&'static str, CounterTotals)> {
        [
            ("primary", self.primary),
            ("shadow", self.shadow),
            ("bounce", self.bounce),
            ("ao", self.ao),
            ("diffuse", self.diffuse),
            ("specular", self.specular),
        ]
        .into_iter()
        .filter(|(_, c)| c.rays > 0)
        .collect()
    }
}

impl AddAssign for FrameStats {
    fn add_assign(&mut self, o: FrameStats) {
        self.primary += o.primary;
        self.shadow += o.shadow;
        self.bounce += o.bounce;
        self.ao += o.ao;
        self.diffuse += o.diffuse;
        self.specular += o.specular;
    }
}

/// Everything fixed for a frame.
#[derive(Clone, Debug)]
pub struct WorkloadParams {
    pub kind: WorkloadKind,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub specular_bounces: u32,
    pub ao_radius: f32,
    pub seed: u64,
}

/// The result of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelResult {
    /// Linear radiance (or AO value), averaged over samples.
    pub color: Vec3,
    /// Nodes visited by all of the pixel's rays (heat map).
    pub nodes_visited: u32,
}

/// Shades pixels of one frame.
#[derive(Debug)]
pub struct Integrator<'a> {
    scene: &'a Scene,
    tracer: &'a Tracer,
    p: WorkloadParams,
    basis: (Vec3, Vec3, Vec3),
    /// Offset of secondary-ray origins along the surface normal, in scene units.
    eps: f32,
}

/// Colour of rays that leave the scene: black for path tracing (only the point light and
/// emitters light the scene), white "sky" for AO/diffuse visibility images.
const SKY: Vec3 = Vec3::splat(1.0);

impl<'a> Integrator<'a> {
    pub fn new(scene: &'a Scene, tracer: &'a Tracer, p: WorkloadParams) -> Self {
        let b = scene.bounds();
        // Assumed: 1e-5 of the scene diagonal clears float error at hit points for the
        // shipped scenes (coordinates up to ~2000 units in f32 have ~1e-4 ulp) without
        // visibly detaching shadows.
        let diag = if b.is_empty() {
            1.0
        } else {
            b.extent().length().max(f32::MIN_POSITIVE)
        };
        let max_coord = if b.is_empty() {
            1.0
        } else {
            b.min.abs().max(b.max.abs()).max_component()
        };
        let eps = (1e-5 * diag).max(2e-6 * max_coord);
        Integrator {
            scene,
            tracer,
            basis: scene.camera.basis(),
            p,
            eps,
        }
    }

    pub fn params(&self) -> &WorkloadParams {
        &self.p
    }

    /// The camera ray through pixel (x, y) for sample `s`: the pixel centre for the first
    /// sample, jittered uniformly within the pixel for further samples of `primary`/`path`/
    /// `specular`.
    #[inline]
    pub fn camera_ray(&self, x: u32, y: u32, jitter: (f32, f32)) -> Ray {
        let cam = &self.scene.camera;
        let d = cam.direction_through(
            &self.basis,
            x as f32 + jitter.0,
            y as f32 + jitter.1,
            self.p.width,
            self.p.height,
        );
        Ray::new(cam.eye, d.normalized(), 0.0, f32::INFINITY)
    }

    /// Geometric normal of the hit triangle, facing against `dir`, and the hit point pushed
    /// off the surface along it.
    #[inline]
    fn surface(&self, ray: &Ray, h: &Hit) -> (Vec3, Vec3) {
        let t = &self.scene.triangles[h.prim as usize];
        let mut n = (t[1] - t[0]).cross(t[2] - t[0]).normalized();
        if n.dot(ray.direction) > 0.0 {
            n = -n;
        }
        // Interpolate from the vertices rather than o + t·d: more precise far from the origin.
        let p = t[0] * (1.0 - h.u - h.v) + t[1] * h.u + t[2] * h.v;
        (n, p + n * self.eps)
    }

    /// Trace and shade pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32, st: &mut FrameStats) -> PixelResult {
        let pixel_index = y as u64 * self.p.width as u64 + x as u64;
        let mut rng = Pcg32::new(stream_seed(self.p.seed, pixel_index, 0), pixel_index);
        let mut out = PixelResult::default();
        match self.p.kind {
            WorkloadKind::Primary => {
                let mut sum = Vec3::ZERO;
                for s in 0..self.p.spp {
                    sum += self.primary_shade(x, y, s, &mut rng, &mut out, st);
                }
                out.color = sum / self.p.spp as f32;
            }
            WorkloadKind::Ao | WorkloadKind::Diffuse => {
                self.ao_or_diffuse(x, y, &mut rng, &mut out, st)
            }
            WorkloadKind::Path => {
                let mut sum = Vec3::ZERO;
                for s in 0..self.p.spp {
                    sum += self.path(x, y, s, &mut rng, &mut out, st);
                }
                out.color = sum / self.p.spp as f32;
            }
            WorkloadKind::Specular => {
                let mut sum = Vec3::ZERO;
                for s in 0..self.p.spp {
                    sum += self.specular(x, y, s, &mut rng, &mut out, st);
                }
                out.color = sum / self.p.spp as f32;
            }
        }
        out
    }

    #[inline]
    fn jitter(s: u32, rng: &mut Pcg32) -> (f32, f32) {
        if s == 0 {
            (0.5, 0.5)
        } else {
            (rng.next_f32(), rng.next_f32())
        }
    }

    #[inline]
    fn closest(&self, ray: &Ray, out: &mut PixelResult, totals: &mut CounterTotals) -> Hit {
        let mut c = RayCounters::default();
        let h = self.tracer.closest_hit(ray, &mut c);
        totals.record(&c, h.is_hit());
        out.nodes_visited = out.nodes_visited.saturating_add(c.nodes_visited);
        h
    }

    #[inline]
    fn occluded(&self, ray: &Ray, out: &mut PixelResult, totals: &mut CounterTotals) -> bool {
        let mut c = RayCounters::default();
        let h = self.tracer.any_hit(ray, &mut c);
        totals.record(&c, h);
        out.nodes_visited = out.nodes_visited.saturating_add(c.nodes_visited);
        h
    }

    /// Unshadowed Lambertian response to the point light at `p` with normal `n`.
    #[inline]
    fn direct_unshadowed(&self, p: Vec3, n: Vec3, albedo: Vec3) -> Vec3 {
        let l = self.scene.light.position - p;
        let d2 = l.length_squared().max(f32::MIN_POSITIVE);
        let cos = (n.dot(l) / d2.sqrt()).max(0.0);
        albedo.mul_elem(self.scene.light.intensity) * (FRAC_1_PI * cos / d2)
    }

    fn primary_shade(
        &self,
        x: u32,
        y: u32,
        s: u32,
        rng: &mut Pcg32,
        out: &mut PixelResult,
        st: &mut FrameStats,
    ) -> Vec3 {
        let ray = self.camera_ray(x, y, Self::jitter(s, rng));
        let h = self.closest(&ray, out, &mut st.primary);
        if !h.is_hit() {
            return Vec3::ZERO;
        }
        let (n, _) = self.surface(&ray, &h);
        // Headlight shading: albedo scaled by the cosine to the viewer.
        let m = self.scene.material_of(h.prim);
        m.albedo * (0.2 + 0.8 * n.dot(-ray.direction).max(0.0)) + m.emission
    }

    fn ao_or_diffuse(
        &self,
        x: u32,
        y: u32,
        rng: &mut Pcg32,
        out: &mut PixelResult,
        st: &mut FrameStats,
    ) {
        let ray = self.camera_ray(x, y, (0.5, 0.5));
        let h = self.closest(&ray, out, &mut st.primary);
        if !h.is_hit() {
            out.color = SKY;
            return;
        }
        let (n, p) = self.surface(&ray, &h);
        let offset = (rng.next_f32(), rng.next_f32());
        let albedo = self.scene.material_of(h.prim).albedo;
        let mut sum = Vec3::ZERO;
        for i in 0..self.p.spp {
            let r = self.secondary_ray(n, p, offset, i);
            if self.p.kind == WorkloadKind::Ao {
                if !self.occluded(&r, out, &mut st.ao) {
                    sum += Vec3::ONE;
                }
            } else {
                let h2 = self.closest(&r, out, &mut st.diffuse);
                // One-bounce inter-reflection: the secondary surface's albedo lit by the
                // unshadowed point light, or the sky.
                sum += if h2.is_hit() {
                    let (n2, p2) = self.surface(&r, &h2);
                    let m2 = self.scene.material_of(h2.prim);
                    self.direct_unshadowed(p2, n2, m2.albedo) + m2.emission
                } else {
                    SKY
                };
            }
        }
        let mean = sum / self.p.spp as f32;
        out.color = if self.p.kind == WorkloadKind::Ao {
            mean
        } else {
            albedo.mul_elem(mean)
        };
    }

    /// The `i`-th AO or diffuse ray from surface point `p` with normal `n`: a cosine-weighted
    /// Halton direction; AO rays end at `ao_radius`, diffuse rays are unbounded.
    #[inline]
    fn secondary_ray(&self, n: Vec3, p: Vec3, offset: (f32, f32), i: u32) -> Ray {
        let (u, v) = halton2(i, offset);
        let tmax = if self.p.kind == WorkloadKind::Ao {
            self.p.ao_radius
        } else {
            f32::INFINITY
        };
        Ray::new(p, cosine_hemisphere(n, u, v), 0.0, tmax)
    }

    /// The rays of pixel (x, y) that a benchmark of this workload times: the camera ray for
    /// `primary`, the AO or diffuse rays for `ao` / `diffuse` (exactly the rays `pixel`
    /// traces, found by tracing the camera ray first), the camera rays otherwise.
    pub fn benchmark_rays(&self, x: u32, y: u32, out: &mut Vec<Ray>) {
        let camera = self.camera_ray(x, y, (0.5, 0.5));
        match self.p.kind {
            WorkloadKind::Ao | WorkloadKind::Diffuse => {
                let pixel_index = y as u64 * self.p.width as u64 + x as u64;
                let mut rng = Pcg32::new(stream_seed(self.p.seed, pixel_index, 0), pixel_index);
                let h = self
                    .tracer
                    .closest_hit(&camera, &mut RayCounters::default());
                if h.is_hit() {
                    let (n, p) = self.surface(&camera, &h);
                    let offset = (rng.next_f32(), rng.next_f32());
                    out.extend((0..self.p.spp).map(|i| self.secondary_ray(n, p, offset, i)));
                }
            }
            _ => out.push(camera),
        }
    }

    /// One path: camera ray, then at each hit a shadow ray to the point light and (until
    /// `max_depth` hits) a cosine-weighted bounce. Lambertian BRDF albedo/π with cosine
    /// sampling: the throughput is multiplied by the albedo.
    fn path(
        &self,
        x: u32,
        y: u32,
        s: u32,
        rng: &mut Pcg32,
        out: &mut PixelResult,
        st: &mut FrameStats,
    ) -> Vec3 {
        let mut ray = self.camera_ray(x, y, Self::jitter(s, rng));
        let mut throughput = Vec3::ONE;
        let mut radiance = Vec3::ZERO;
        for depth in 0..self.p.max_depth {
            let totals = if depth == 0 {
                &mut st.primary
            } else {
                &mut st.bounce
            };
            let h = self.closest(&ray, out, totals);
            if !h.is_hit() {
                break;
            }
            let (n, p) = self.surface(&ray, &h);
            let m = self.scene.material_of(h.prim);
            radiance += throughput.mul_elem(m.emission);
            // Shadow ray towards the light (t = 1 at the light). One per hit, as in the
            // papers' non-branching paths, even when the light is behind the surface.
            let to_light = self.scene.light.position - p;
            let shadow = Ray::new(p, to_light, 0.0, 1.0 - 1e-4);
            if !self.occluded(&shadow, out, &mut st.shadow) {
                radiance += throughput.mul_elem(self.direct_unshadowed(p, n, m.albedo));
            }
            throughput = throughput.mul_elem(m.albedo);
            if depth + 1 == self.p.max_depth {
                break;
            }
            let dir = cosine_hemisphere(n, rng.next_f32(), rng.next_f32());
            ray = Ray::new(p, dir, 0.0, f32::INFINITY);
        }
        radiance
    }

    /// Forced specular: mirror reflection at every hit, `specular_bounces` times; the last
    /// surface is shaded by the unshadowed point light, tinted by the albedos on the way.
    fn specular(
        &self,
        x: u32,
        y: u32,
        s: u32,
        rng: &mut Pcg32,
        out: &mut PixelResult,
        st: &mut FrameStats,
    ) -> Vec3 {
        let mut ray = self.camera_ray(x, y, Self::jitter(s, rng));
        let mut tint = Vec3::ONE;
        let mut last = Vec3::ZERO;
        for bounce in 0..=self.p.specular_bounces {
            let totals = if bounce == 0 {
                &mut st.primary
            } else {
                &mut st.specular
            };
            let h = self.closest(&ray, out, totals);
            if !h.is_hit() {
                break;
            }
            let (n, p) = self.surface(&ray, &h);
            let m = self.scene.material_of(h.prim);
            last = tint.mul_elem(self.direct_unshadowed(p, n, m.albedo) + m.emission);
            tint = tint.mul_elem(m.albedo);
            let d = ray.direction;
            ray = Ray::new(p, d - n * (2.0 * d.dot(n)), 0.0, f32::INFINITY);
        }
        last
    }
}
