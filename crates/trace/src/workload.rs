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
use crate::shade;
use crate::step::Query;
use crate::tracer::{Hit, Tracer};
use crate::traverse::SlotHit;
use rtsim_core::rng::stream_seed;
use rtsim_core::{Pcg32, Ray, Vec3};
use rtsim_scene::{Material, Scene};
use rtsim_stats_derive::Stats;
use serde::{Deserialize, Serialize};

/// Counters per ray kind for a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Stats)]
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

impl FrameStats {
    /// The totals that count rays of `kind`.
    #[inline]
    pub fn kind_mut(&mut self, kind: RayKind) -> &mut CounterTotals {
        match kind {
            RayKind::Primary => &mut self.primary,
            RayKind::Shadow => &mut self.shadow,
            RayKind::Bounce => &mut self.bounce,
            RayKind::Ao => &mut self.ao,
            RayKind::Diffuse => &mut self.diffuse,
            RayKind::Specular => &mut self.specular,
        }
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

/// Why a ray is traced; decides which [`FrameStats`] field counts it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum RayKind {
    /// Camera ray (the first segment of every sample).
    Primary = 0,
    /// Path tracing: towards the point light (any hit).
    Shadow = 1,
    /// Path tracing: cosine-weighted bounce.
    Bounce = 2,
    /// Ambient occlusion (any hit, bounded by the AO radius).
    Ao = 3,
    /// One-bounce diffuse inter-reflection.
    Diffuse = 4,
    /// Forced specular: mirror reflection.
    Specular = 5,
}

/// Which ray of the frame a job is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RayId {
    /// Pixel index, row-major (`y · width + x`).
    pub pixel: u32,
    /// Sample of the pixel (always 0 for AO and diffuse, whose `spp` rays hang off one
    /// camera ray).
    pub sample: u32,
    /// Ray of the sample, in tracing order (0 = the camera ray).
    pub segment: u32,
    pub kind: RayKind,
}

/// A ray to trace, with who asked for it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayJob {
    pub id: RayId,
    pub ray: Ray,
    pub query: Query,
}

/// What tracing a [`RayJob`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceResult {
    /// In scene terms (scene triangle id); for any-hit queries, the hit that ended the ray.
    pub hit: Hit,
    /// The BVH triangle slot of the hit (`u32::MAX` for a miss): where its record lives.
    pub slot: u32,
}

impl TraceResult {
    pub fn from_slot_hit(tracer: &Tracer, h: SlotHit) -> TraceResult {
        TraceResult {
            hit: tracer.slot_to_scene(h),
            slot: h.slot,
        }
    }
}

/// The shading kernels a [`Integrator::begin`] or [`Integrator::resume`] call ran, counted.
/// The operation mix of each is published by [`crate::ops`]; the hardware models charge
/// them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Kernel {
    /// A camera ray through a pixel position (basis, normalisation).
    CameraRay = 0,
    /// Two uniform random numbers for a sub-pixel jitter.
    Jitter = 1,
    /// The hit point and geometric normal from the hit triangle's vertices.
    Surface = 2,
    /// Headlight shading of a primary hit.
    Headlight = 3,
    /// Unshadowed Lambertian response to the point light.
    DirectLight = 4,
    /// A shadow ray towards the light.
    ShadowRay = 5,
    /// A cosine-weighted direction from two random numbers (path-tracing bounce).
    CosineBounce = 6,
    /// A Halton-sequence cosine direction (AO and diffuse rays).
    HaltonRay = 7,
    /// A mirror reflection.
    Reflect = 8,
    /// `sum += x` on a colour (3 additions).
    Accumulate = 9,
    /// `acc += w ⊙ x` (or `acc = w ⊙ (x + y)`): 3 multiplies and 3 additions.
    Weighted = 10,
    /// `t = t ⊙ a`: 3 multiplies.
    Attenuate = 11,
    /// Average the samples (one divide, 3 multiplies) and write the framebuffer.
    Finish = 12,
}

/// Number of [`Kernel`] kinds.
pub const KERNELS: usize = 13;

/// What one state-machine transition did besides tracing: the kernels it ran and the
/// records it read or wrote, by index (the memory image gives their addresses).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Shading {
    /// Runs of each [`Kernel`], indexed by `Kernel as usize`.
    pub kernels: [u8; KERNELS],
    /// BVH slot of a triangle record read (hit point and normal).
    pub triangle: Option<u32>,
    /// Material record read.
    pub material: Option<u32>,
    /// Pixel whose framebuffer entry was written.
    pub framebuffer: Option<u32>,
}

/// Which record a transition touched.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Record {
    /// The hit triangle's vertices.
    Triangle,
    Material,
    /// The pixel's framebuffer entry.
    Framebuffer,
}

/// One record a transition read or wrote, located in the memory image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordAccess {
    pub record: Record,
    /// First byte and bytes touched (the fields used, not the record's padding).
    pub addr: u64,
    pub bytes: u32,
    pub write: bool,
    pub lines: rtsim_bvh::LineSpan,
}

impl Shading {
    /// The records this transition read or wrote, with their addresses and cache lines: the
    /// hit triangle's vertices (36 bytes of its record), its material, the framebuffer pixel.
    /// Materials and the framebuffer are located only if the image has their regions
    /// (`MemoryImage::build` with the run's `ImageExtras`, as every command builds it).
    pub fn accesses(
        &self,
        image: &rtsim_bvh::MemoryImage,
        line_bytes: u32,
    ) -> impl Iterator<Item = RecordAccess> + use<> {
        use rtsim_bvh::{RecordKind, lines_touched};
        let at = |record, addr, bytes, write| RecordAccess {
            record,
            addr,
            bytes,
            write,
            lines: lines_touched(addr, bytes, line_bytes),
        };
        let vertices = self
            .triangle
            .map(|slot| at(Record::Triangle, image.triangle_addr(slot), 36, false));
        let region = |kind: RecordKind, i: u32, record, write| {
            let set = image.records(kind)?;
            Some(at(record, set.placement.addr(i), set.data_bytes, write))
        };
        let material = self
            .material
            .and_then(|m| region(RecordKind::Material, m, Record::Material, false));
        let pixel = self
            .framebuffer
            .and_then(|p| region(RecordKind::Pixel, p, Record::Framebuffer, true));
        [vertices, material, pixel].into_iter().flatten()
    }

    #[inline(always)]
    fn run(&mut self, k: Kernel) {
        self.kernels[k as usize] += 1;
    }
    /// Runs of kernel `k`.
    pub fn count(&self, k: Kernel) -> u32 {
        self.kernels[k as usize] as u32
    }
}

/// What comes after a transition.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Next {
    /// Trace this ray, then call [`Integrator::resume`] with its result.
    Trace(RayJob),
    /// The pixel is finished with this colour (linear radiance or AO value).
    Done(Vec3),
}

/// One transition of a pixel's state machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resumed {
    pub next: Next,
    pub shading: Shading,
}

/// Where a pixel is in its work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// Waiting for a camera ray (primary, path and specular: a closest-hit segment).
    Segment,
    /// AO/diffuse: waiting for the camera ray.
    Camera,
    /// AO/diffuse: waiting for secondary ray `i`.
    Secondary,
    /// Path tracing: waiting for the shadow ray of the current hit.
    Shadow,
}

/// Everything a pixel carries between its rays (plain data: a hardware model parks it
/// beside the ray, or spills it to memory). The pixel's random stream lives here; the
/// samples of one pixel run one after the other because they draw from that one stream
/// (which keeps images identical to the per-pixel loop they replaced).
#[derive(Clone, Copy, Debug)]
pub struct PathState {
    pixel: u32,
    x: u32,
    y: u32,
    sample: u32,
    segment: u32,
    stage: Stage,
    rng: Pcg32,
    /// Sum over samples (primary, path, specular) or over secondary rays (AO, diffuse).
    sum: Vec3,
    /// Path: throughput and radiance of the current sample; specular: tint and last value.
    throughput: Vec3,
    radiance: Vec3,
    /// Path: hits so far in this sample; specular: bounce; AO/diffuse: secondary ray index.
    depth: u32,
    /// Hit point (pushed off the surface) and normal of the current hit.
    p: Vec3,
    n: Vec3,
    /// Path: the light's unshadowed contribution waiting on the shadow ray; AO/diffuse: the
    /// camera hit's albedo.
    pending: Vec3,
    albedo: Vec3,
    /// AO/diffuse: the pixel's Cranley–Patterson rotation of the Halton sequence.
    offset: (f32, f32),
}

impl PathState {
    /// The pixel index (row-major).
    pub fn pixel(&self) -> u32 {
        self.pixel
    }
}

/// Shades pixels of one frame: each pixel is a state machine ([`Integrator::begin`],
/// [`Integrator::resume`]) that asks for rays to be traced and shades their results, so that
/// a hardware model can trace the rays on its own schedule.
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

    pub fn tracer(&self) -> &Tracer {
        self.tracer
    }

    /// The camera ray through pixel (x, y) for sample `s`: the pixel centre for the first
    /// sample, jittered uniformly within the pixel for further samples of `primary`/`path`/
    /// `specular`.
    #[inline]
    pub fn camera_ray(&self, x: u32, y: u32, jitter: (f32, f32)) -> Ray {
        let cam = &self.scene.camera;
        let (tan_half, aspect) = cam.frame_constants(self.p.width, self.p.height);
        let d = shade::camera_ray_direction(
            &self.basis,
            tan_half,
            aspect,
            x as f32 + jitter.0,
            y as f32 + jitter.1,
            self.p.width as f32,
            self.p.height as f32,
        );
        Ray::new(cam.eye, d, 0.0, f32::INFINITY)
    }

    /// Geometric normal of the hit triangle, facing against `dir`, and the hit point pushed
    /// off the surface along it.
    #[inline]
    fn surface(&self, ray: &Ray, h: &Hit) -> (Vec3, Vec3) {
        let t = &self.scene.triangles[h.prim as usize];
        shade::surface(t, h.u, h.v, ray.direction, self.eps)
    }

    /// Unshadowed Lambertian response to the point light at `p` with normal `n`.
    #[inline]
    fn direct_unshadowed(&self, p: Vec3, n: Vec3, albedo: Vec3) -> Vec3 {
        let l = &self.scene.light;
        shade::direct_unshadowed(l.position, l.intensity, p, n, albedo)
    }

    #[inline]
    fn jitter(s: u32, rng: &mut Pcg32, sh: &mut Shading) -> (f32, f32) {
        if s == 0 {
            (0.5, 0.5)
        } else {
            sh.run(Kernel::Jitter);
            (rng.next_f32(), rng.next_f32())
        }
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

    /// A job for the pixel's next ray.
    #[inline]
    fn job(&self, st: &mut PathState, ray: Ray, kind: RayKind, query: Query) -> Next {
        let id = RayId {
            pixel: st.pixel,
            sample: st.sample,
            segment: st.segment,
            kind,
        };
        st.segment += 1;
        Next::Trace(RayJob { id, ray, query })
    }

    /// The camera ray of the pixel's current sample.
    #[inline]
    fn camera_job(&self, st: &mut PathState, sh: &mut Shading) -> Next {
        let j = Self::jitter(st.sample, &mut st.rng, sh);
        sh.run(Kernel::CameraRay);
        let ray = self.camera_ray(st.x, st.y, j);
        st.segment = 0;
        self.job(st, ray, RayKind::Primary, Query::Closest)
    }

    /// Start pixel `pixel` (row-major index): its state and the first ray to trace.
    pub fn begin(&self, pixel: u32) -> (PathState, Resumed) {
        let (x, y) = (pixel % self.p.width, pixel / self.p.width);
        let rng = Pcg32::new(stream_seed(self.p.seed, pixel as u64, 0), pixel as u64);
        let mut st = PathState {
            pixel,
            x,
            y,
            sample: 0,
            segment: 0,
            stage: Stage::Segment,
            rng,
            sum: Vec3::ZERO,
            throughput: Vec3::ONE,
            radiance: Vec3::ZERO,
            depth: 0,
            p: Vec3::ZERO,
            n: Vec3::ZERO,
            pending: Vec3::ZERO,
            albedo: Vec3::ZERO,
            offset: (0.0, 0.0),
        };
        let mut sh = Shading::default();
        let next = match self.p.kind {
            WorkloadKind::Ao | WorkloadKind::Diffuse => {
                // One camera ray through the centre; `spp` secondary rays hang off its hit.
                st.stage = Stage::Camera;
                sh.run(Kernel::CameraRay);
                let ray = self.camera_ray(x, y, (0.5, 0.5));
                self.job(&mut st, ray, RayKind::Primary, Query::Closest)
            }
            _ => self.camera_job(&mut st, &mut sh),
        };
        (st, Resumed { next, shading: sh })
    }

    /// A sample of a primary/path/specular pixel is finished with `value`: start the next
    /// sample or finish the pixel.
    #[inline]
    fn end_sample(&self, st: &mut PathState, value: Vec3, sh: &mut Shading) -> Next {
        sh.run(Kernel::Accumulate);
        st.sum += value;
        st.sample += 1;
        if st.sample == self.p.spp {
            self.finish(st, st.sum / self.p.spp as f32, sh)
        } else {
            st.stage = Stage::Segment;
            st.throughput = Vec3::ONE;
            st.radiance = Vec3::ZERO;
            st.depth = 0;
            self.camera_job(st, sh)
        }
    }

    #[inline]
    fn finish(&self, st: &PathState, color: Vec3, sh: &mut Shading) -> Next {
        sh.run(Kernel::Finish);
        sh.framebuffer = Some(st.pixel);
        Next::Done(color)
    }

    /// Continue pixel `st` with the result of tracing `job` (the job the previous
    /// transition asked for).
    pub fn resume(&self, st: &mut PathState, job: &RayJob, r: &TraceResult) -> Resumed {
        let mut sh = Shading::default();
        let h = &r.hit;
        let ray = &job.ray;
        let next = match (self.p.kind, st.stage) {
            (WorkloadKind::Primary, _) => {
                // Headlight shading: albedo scaled by the cosine to the viewer.
                let value = if h.is_hit() {
                    let (n, _) = self.read_surface(ray, r, &mut sh);
                    sh.run(Kernel::Headlight);
                    let m = self.material(h.prim, &mut sh);
                    shade::headlight(m.albedo, m.emission, n, ray.direction)
                } else {
                    Vec3::ZERO
                };
                self.end_sample(st, value, &mut sh)
            }
            (WorkloadKind::Ao | WorkloadKind::Diffuse, Stage::Camera) => {
                if !h.is_hit() {
                    return Resumed {
                        next: self.finish(st, SKY, &mut sh),
                        shading: sh,
                    };
                }
                let (n, p) = self.read_surface(ray, r, &mut sh);
                st.offset = (st.rng.next_f32(), st.rng.next_f32());
                st.albedo = self.material(h.prim, &mut sh).albedo;
                st.n = n;
                st.p = p;
                st.depth = 0;
                st.sum = Vec3::ZERO;
                st.stage = Stage::Secondary;
                self.secondary_job(st, &mut sh)
            }
            (WorkloadKind::Ao | WorkloadKind::Diffuse, _) => {
                if self.p.kind == WorkloadKind::Ao {
                    if !h.is_hit() {
                        sh.run(Kernel::Accumulate);
                        st.sum += Vec3::ONE;
                    }
                } else {
                    // One-bounce inter-reflection: the secondary surface's albedo lit by the
                    // unshadowed point light, or the sky.
                    sh.run(Kernel::Accumulate);
                    st.sum += if h.is_hit() {
                        let (n2, p2) = self.read_surface(ray, r, &mut sh);
                        let m2 = self.material(h.prim, &mut sh);
                        sh.run(Kernel::DirectLight);
                        sh.run(Kernel::Accumulate);
                        self.direct_unshadowed(p2, n2, m2.albedo) + m2.emission
                    } else {
                        SKY
                    };
                }
                st.depth += 1;
                if st.depth == self.p.spp {
                    let mean = st.sum / self.p.spp as f32;
                    let color = if self.p.kind == WorkloadKind::Ao {
                        mean
                    } else {
                        sh.run(Kernel::Attenuate);
                        st.albedo.mul_elem(mean)
                    };
                    self.finish(st, color, &mut sh)
                } else {
                    self.secondary_job(st, &mut sh)
                }
            }
            (WorkloadKind::Path, Stage::Shadow) => {
                if !h.is_hit() {
                    sh.run(Kernel::Weighted);
                    st.radiance += st.throughput.mul_elem(st.pending);
                }
                sh.run(Kernel::Attenuate);
                st.throughput = st.throughput.mul_elem(st.albedo);
                st.depth += 1;
                if st.depth == self.p.max_depth {
                    self.end_sample(st, st.radiance, &mut sh)
                } else {
                    sh.run(Kernel::CosineBounce);
                    let dir = shade::cosine_bounce(st.n, st.rng.next_f32(), st.rng.next_f32());
                    st.stage = Stage::Segment;
                    let ray = Ray::new(st.p, dir, 0.0, f32::INFINITY);
                    self.job(st, ray, RayKind::Bounce, Query::Closest)
                }
            }
            (WorkloadKind::Path, _) => {
                if !h.is_hit() {
                    return Resumed {
                        next: self.end_sample(st, st.radiance, &mut sh),
                        shading: sh,
                    };
                }
                let (n, p) = self.read_surface(ray, r, &mut sh);
                let m = self.material(h.prim, &mut sh);
                sh.run(Kernel::Weighted);
                st.radiance += st.throughput.mul_elem(m.emission);
                // Shadow ray towards the light (t = 1 at the light). One per hit, as in the
                // papers' non-branching paths, even when the light is behind the surface.
                sh.run(Kernel::DirectLight);
                st.pending = self.direct_unshadowed(p, n, m.albedo);
                st.albedo = m.albedo;
                st.n = n;
                st.p = p;
                st.stage = Stage::Shadow;
                sh.run(Kernel::ShadowRay);
                let to_light = shade::shadow_direction(self.scene.light.position, p);
                let shadow = Ray::new(p, to_light, 0.0, 1.0 - 1e-4);
                self.job(st, shadow, RayKind::Shadow, Query::Any)
            }
            (WorkloadKind::Specular, _) => {
                // Mirror reflection at every hit; the last surface is shaded by the unshadowed
                // point light, tinted by the albedos on the way.
                if !h.is_hit() {
                    return Resumed {
                        next: self.end_sample(st, st.radiance, &mut sh),
                        shading: sh,
                    };
                }
                let (n, p) = self.read_surface(ray, r, &mut sh);
                let m = self.material(h.prim, &mut sh);
                sh.run(Kernel::DirectLight);
                sh.run(Kernel::Weighted);
                st.radiance = st
                    .throughput
                    .mul_elem(self.direct_unshadowed(p, n, m.albedo) + m.emission);
                sh.run(Kernel::Attenuate);
                st.throughput = st.throughput.mul_elem(m.albedo);
                if st.depth == self.p.specular_bounces {
                    self.end_sample(st, st.radiance, &mut sh)
                } else {
                    st.depth += 1;
                    sh.run(Kernel::Reflect);
                    let d = ray.direction;
                    let refl = Ray::new(p, shade::reflect(d, n), 0.0, f32::INFINITY);
                    self.job(st, refl, RayKind::Specular, Query::Closest)
                }
            }
        };
        Resumed { next, shading: sh }
    }

    /// The hit point and normal, reading the hit triangle's record.
    #[inline]
    fn read_surface(&self, ray: &Ray, r: &TraceResult, sh: &mut Shading) -> (Vec3, Vec3) {
        sh.run(Kernel::Surface);
        sh.triangle = Some(r.slot);
        self.surface(ray, &r.hit)
    }

    /// The hit triangle's material, reading its record.
    #[inline]
    fn material(&self, prim: u32, sh: &mut Shading) -> &Material {
        let id = self.scene.material_ids[prim as usize];
        sh.material = Some(id);
        &self.scene.materials[id as usize]
    }

    /// The next AO or diffuse ray of an AO/diffuse pixel.
    #[inline]
    fn secondary_job(&self, st: &mut PathState, sh: &mut Shading) -> Next {
        sh.run(Kernel::HaltonRay);
        let r = self.secondary_ray(st.n, st.p, st.offset, st.depth);
        let (kind, query) = if self.p.kind == WorkloadKind::Ao {
            (RayKind::Ao, Query::Any)
        } else {
            (RayKind::Diffuse, Query::Closest)
        };
        self.job(st, r, kind, query)
    }

    /// Trace a job with the tracer's configured variant, counting it.
    #[inline]
    pub fn trace(&self, job: &RayJob, c: &mut RayCounters) -> TraceResult {
        TraceResult::from_slot_hit(self.tracer, self.tracer.trace_slots(&job.ray, job.query, c))
    }

    /// Trace and shade pixel (x, y): the state machine run to its end.
    pub fn pixel(&self, x: u32, y: u32, st: &mut FrameStats) -> PixelResult {
        let mut out = PixelResult::default();
        let (mut ps, mut step) = self.begin(y * self.p.width + x);
        loop {
            match step.next {
                Next::Done(color) => {
                    out.color = color;
                    return out;
                }
                Next::Trace(job) => {
                    let mut c = RayCounters::default();
                    let r = self.trace(&job, &mut c);
                    st.kind_mut(job.id.kind).record(&c, r.hit.is_hit());
                    out.nodes_visited = out.nodes_visited.saturating_add(c.nodes_visited);
                    step = self.resume(&mut ps, &job, &r);
                }
            }
        }
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TraceConfig;
    use rtsim_scene::{SceneRequest, load_scene};

    fn cornell() -> Scene {
        load_scene(&SceneRequest {
            name: "cornell",
            size: 1.0,
            seed: 1,
            scene_dir: None,
        })
        .unwrap()
    }

    /// The Cornell box and its default BVH.
    fn cornell_bvh() -> (Scene, rtsim_bvh::Bvh) {
        let scene = cornell();
        let bvh = rtsim_bvh::build(
            &scene.triangles,
            &Default::default(),
            rtsim_bvh::NodeOrder::DepthFirst,
        )
        .unwrap();
        (scene, bvh)
    }

    fn params(kind: WorkloadKind, spp: u32) -> WorkloadParams {
        WorkloadParams {
            kind,
            width: 24,
            height: 18,
            spp,
            max_depth: 5,
            specular_bounces: 2,
            ao_radius: 0.3,
            seed: 3,
        }
    }

    const KINDS: [WorkloadKind; 5] = [
        WorkloadKind::Primary,
        WorkloadKind::Ao,
        WorkloadKind::Diffuse,
        WorkloadKind::Path,
        WorkloadKind::Specular,
    ];

    /// A chip interleaves many pixels' rays: the state machines must carry everything, so
    /// any interleaving gives the pixel-by-pixel image and counters.
    #[test]
    fn interleaved_pixels_equal_pixel_by_pixel() {
        let (scene, bvh) = cornell_bvh();
        let tracer = Tracer::new(&scene.triangles, bvh, &TraceConfig::default()).unwrap();
        for kind in KINDS {
            for spp in [1, 2] {
                let integ = Integrator::new(&scene, &tracer, params(kind, spp));
                let (w, h) = (integ.params().width, integ.params().height);
                let mut reference = FrameStats::default();
                let expected: Vec<Vec3> = (0..w * h)
                    .map(|i| integ.pixel(i % w, i / w, &mut reference).color)
                    .collect();
                // Round-robin: one ray of each live pixel in turn, newest pixels last.
                let mut live: Vec<(PathState, RayJob)> = Vec::new();
                let mut got = vec![Vec3::splat(-1.0); (w * h) as usize];
                let mut stats = FrameStats::default();
                let mut next_pixel = 0;
                while next_pixel < w * h || !live.is_empty() {
                    while live.len() < 7 && next_pixel < w * h {
                        let (st, r) = integ.begin(next_pixel);
                        let Next::Trace(job) = r.next else {
                            panic!("a pixel starts with a ray")
                        };
                        assert_eq!(r.shading.count(Kernel::CameraRay), 1);
                        live.push((st, job));
                        next_pixel += 1;
                    }
                    let (mut st, job) = live.remove(0);
                    let mut c = RayCounters::default();
                    let res = integ.trace(&job, &mut c);
                    stats.kind_mut(job.id.kind).record(&c, res.hit.is_hit());
                    let r = integ.resume(&mut st, &job, &res);
                    if res.hit.is_hit() && r.shading.count(Kernel::Surface) > 0 {
                        assert_eq!(r.shading.triangle, Some(res.slot));
                        assert_eq!(
                            r.shading.material,
                            Some(scene.material_ids[res.hit.prim as usize])
                        );
                    }
                    match r.next {
                        Next::Trace(j) => {
                            assert_eq!(j.id.pixel, job.id.pixel);
                            assert!((j.id.sample, j.id.segment) > (job.id.sample, job.id.segment));
                            live.push((st, j));
                        }
                        Next::Done(c) => {
                            assert_eq!(r.shading.framebuffer, Some(job.id.pixel));
                            assert_eq!(r.shading.count(Kernel::Finish), 1);
                            got[job.id.pixel as usize] = c;
                        }
                    }
                }
                for (a, b) in expected.iter().zip(&got) {
                    assert_eq!(
                        a.to_array().map(f32::to_bits),
                        b.to_array().map(f32::to_bits)
                    );
                }
                assert_eq!(stats, reference, "{kind:?}");
            }
        }
    }

    #[test]
    fn shading_locates_its_records_in_the_image() {
        let (scene, bvh) = cornell_bvh();
        let cfg = rtsim_bvh::MemoryLayoutConfig::default();
        let extras =
            rtsim_bvh::ImageExtras::for_run(&cfg, false, scene.materials.len() as u32, 24, 18);
        let image = rtsim_bvh::MemoryImage::build(&bvh, &cfg, &extras).unwrap();
        let tracer = Tracer::new(&scene.triangles, bvh, &TraceConfig::default()).unwrap();
        let integ = Integrator::new(&scene, &tracer, params(WorkloadKind::Path, 1));
        let mut seen = [false; 3];
        for pixel in 0..24 * 18 {
            let (mut st, mut r) = integ.begin(pixel);
            while let Next::Trace(job) = r.next {
                let res = integ.trace(&job, &mut RayCounters::default());
                r = integ.resume(&mut st, &job, &res);
                for a in r.shading.accesses(&image, 64) {
                    let want = match a.record {
                        Record::Triangle => image.triangle_addr(res.slot),
                        Record::Material => {
                            image.material_addr(scene.material_ids[res.hit.prim as usize])
                        }
                        Record::Framebuffer => image.framebuffer_addr(pixel),
                    };
                    assert_eq!(a.addr, want);
                    assert_eq!(a.write, a.record == Record::Framebuffer);
                    assert!(a.lines.count >= 1);
                    seen[a.record as usize] = true;
                }
            }
        }
        assert_eq!(seen, [true; 3]);
    }

    #[test]
    fn path_segments_follow_the_papers_budget() {
        let (scene, bvh) = cornell_bvh();
        let tracer = Tracer::new(&scene.triangles, bvh, &TraceConfig::default()).unwrap();
        let integ = Integrator::new(&scene, &tracer, params(WorkloadKind::Path, 1));
        for pixel in 0..24 * 18 {
            let (mut st, mut r) = integ.begin(pixel);
            let mut kinds = Vec::new();
            while let Next::Trace(job) = r.next {
                kinds.push(job.id.kind);
                assert_eq!(job.id.segment as usize, kinds.len() - 1);
                let res = integ.trace(&job, &mut RayCounters::default());
                r = integ.resume(&mut st, &job, &res);
            }
            // STRaTA §5: at most 5 hits, each with one shadow ray: 10 segments.
            assert!(kinds.len() <= 10);
            assert_eq!(kinds[0], RayKind::Primary);
            for w in kinds.windows(2) {
                // A shadow ray follows every closest-hit segment that hit; bounces follow
                // shadow rays.
                match w[1] {
                    RayKind::Shadow => assert_ne!(w[0], RayKind::Shadow),
                    RayKind::Bounce => assert_eq!(w[0], RayKind::Shadow),
                    k => panic!("unexpected {k:?}"),
                }
            }
        }
    }
}
