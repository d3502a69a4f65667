//! The classic Cornell box, from the measured data.
//!
//! Geometry: the Cornell University Program of Computer Graphics "Cornell Box Data"
//! (graphics.cornell.edu/online/box/data.html), millimetres, in its own frame (y up, camera
//! at z = −800 looking +z). We rotate it into simtrax's Z-up frame (the frame of
//! `cornell.view` / `cornell.light` in `shared/scenes/cornell-box`) with the proper rotation
//! (x, y, z) ↦ (556 − x, z, y): the box spans 0..556 × 0..559.2 × 0..548.8, the camera at
//! (278, −549, 274) looks +y with +z up, and the red wall is on the left as in the
//! photographs. (simtrax's own `CornellBox.obj` swaps y and z only, a mirror image that
//! puts the red wall on the right; the `cornell-box` descriptor scene keeps that file as is.)
//!
//! The ceiling has a hole where the light is, so the light quad (the data gives both at
//! y = 548.8) is not coplanar with an overlapping ceiling quad.
//!
//! Colours (RGB reflectances and emission) are those of Benedikt Bitterli's rendering
//! resources Cornell box (white 0.725 0.71 0.68, red 0.63 0.065 0.05, green 0.14 0.45 0.091,
//! light reflectance 0.78 and emission 17 12 4), the usual RGB reduction of the measured
//! spectra.

use super::assemble;
use crate::{Camera, Material, Scene, Triangle};
use rtsim_core::Vec3;

/// 2 floor + 8 ceiling (around the light) + 2 light + 3 × 2 walls + 2 × 5 × 2 blocks.
pub(crate) const CORNELL_TRIANGLES: u64 = 38;

/// A quad of the Cornell data (its own frame), as listed on the data page.
type Quad = [[f32; 3]; 4];

const FLOOR: Quad = [
    [552.8, 0.0, 0.0],
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 559.2],
    [549.6, 0.0, 559.2],
];
const LIGHT: Quad = [
    [343.0, 548.8, 227.0],
    [343.0, 548.8, 332.0],
    [213.0, 548.8, 332.0],
    [213.0, 548.8, 227.0],
];
const BACK: Quad = [
    [549.6, 0.0, 559.2],
    [0.0, 0.0, 559.2],
    [0.0, 548.8, 559.2],
    [556.0, 548.8, 559.2],
];
const GREEN_WALL: Quad = [
    [0.0, 0.0, 559.2],
    [0.0, 0.0, 0.0],
    [0.0, 548.8, 0.0],
    [0.0, 548.8, 559.2],
];
const RED_WALL: Quad = [
    [552.8, 0.0, 0.0],
    [549.6, 0.0, 559.2],
    [556.0, 548.8, 559.2],
    [556.0, 548.8, 0.0],
];
const SHORT_BLOCK: [Quad; 5] = [
    [
        [130.0, 165.0, 65.0],
        [82.0, 165.0, 225.0],
        [240.0, 165.0, 272.0],
        [290.0, 165.0, 114.0],
    ],
    [
        [290.0, 0.0, 114.0],
        [290.0, 165.0, 114.0],
        [240.0, 165.0, 272.0],
        [240.0, 0.0, 272.0],
    ],
    [
        [130.0, 0.0, 65.0],
        [130.0, 165.0, 65.0],
        [290.0, 165.0, 114.0],
        [290.0, 0.0, 114.0],
    ],
    [
        [82.0, 0.0, 225.0],
        [82.0, 165.0, 225.0],
        [130.0, 165.0, 65.0],
        [130.0, 0.0, 65.0],
    ],
    [
        [240.0, 0.0, 272.0],
        [240.0, 165.0, 272.0],
        [82.0, 165.0, 225.0],
        [82.0, 0.0, 225.0],
    ],
];
const TALL_BLOCK: [Quad; 5] = [
    [
        [423.0, 330.0, 247.0],
        [265.0, 330.0, 296.0],
        [314.0, 330.0, 456.0],
        [472.0, 330.0, 406.0],
    ],
    [
        [423.0, 0.0, 247.0],
        [423.0, 330.0, 247.0],
        [472.0, 330.0, 406.0],
        [472.0, 0.0, 406.0],
    ],
    [
        [472.0, 0.0, 406.0],
        [472.0, 330.0, 406.0],
        [314.0, 330.0, 456.0],
        [314.0, 0.0, 456.0],
    ],
    [
        [314.0, 0.0, 456.0],
        [314.0, 330.0, 456.0],
        [265.0, 330.0, 296.0],
        [265.0, 0.0, 296.0],
    ],
    [
        [265.0, 0.0, 296.0],
        [265.0, 330.0, 296.0],
        [423.0, 330.0, 247.0],
        [423.0, 0.0, 247.0],
    ],
];

/// Ceiling height and extents (data page: the ceiling quad spans x 0..556, z 0..559.2).
const CEILING_Y: f32 = 548.8;
const CEILING_X: f32 = 556.0;
const CEILING_Z: f32 = 559.2;
/// The light's x and z range (data page), i.e. the hole in the ceiling.
const LIGHT_X: (f32, f32) = (213.0, 343.0);
const LIGHT_Z: (f32, f32) = (227.0, 332.0);

/// simtrax `cornell.view`: eye (278, −549, 274), gaze +y, up +z, image plane [−1, 1]² at
/// distance 2, so the vertical field of view is 2·atan(1/2) = 53.13°.
const EYE: Vec3 = Vec3::new(278.0, -549.0, 274.0);
/// simtrax `cornell.light`: just below the centre of the ceiling light (548.8 − 8.8 mm).
const LIGHT_POSITION: Vec3 = Vec3::new(278.0, 279.5, 540.0);

/// Cornell data frame → simtrax Z-up frame (a proper rotation about the box's vertical
/// mid-plane; see the module comment).
fn to_z_up(p: [f32; 3]) -> Vec3 {
    Vec3::new(CEILING_X - p[0], p[2], p[1])
}

fn quad_triangles(q: &Quad) -> [Triangle; 2] {
    let v = q.map(to_z_up);
    [[v[0], v[1], v[2]], [v[0], v[2], v[3]]]
}

/// An axis-aligned rectangle of the ceiling (data frame x and z ranges).
fn ceiling_rect(x: (f32, f32), z: (f32, f32)) -> Quad {
    [
        [x.0, CEILING_Y, z.0],
        [x.1, CEILING_Y, z.0],
        [x.1, CEILING_Y, z.1],
        [x.0, CEILING_Y, z.1],
    ]
}

/// The Cornell box (38 triangles). Deterministic; has no size or seed.
pub fn cornell() -> Scene {
    let materials = vec![
        Material {
            name: "white".into(),
            albedo: Vec3::new(0.725, 0.71, 0.68),
            emission: Vec3::ZERO,
        },
        Material {
            name: "red".into(),
            albedo: Vec3::new(0.63, 0.065, 0.05),
            emission: Vec3::ZERO,
        },
        Material {
            name: "green".into(),
            albedo: Vec3::new(0.14, 0.45, 0.091),
            emission: Vec3::ZERO,
        },
        Material {
            name: "light".into(),
            albedo: Vec3::splat(0.78),
            emission: Vec3::new(17.0, 12.0, 4.0),
        },
    ];
    let (white, red, green, light) = (0, 1, 2, 3);
    let ceiling = [
        ceiling_rect((0.0, CEILING_X), (0.0, LIGHT_Z.0)),
        ceiling_rect((0.0, CEILING_X), (LIGHT_Z.1, CEILING_Z)),
        ceiling_rect((0.0, LIGHT_X.0), LIGHT_Z),
        ceiling_rect((LIGHT_X.1, CEILING_X), LIGHT_Z),
    ];
    let mut quads: Vec<(&Quad, u32)> = vec![(&FLOOR, white)];
    quads.extend(ceiling.iter().map(|q| (q, white)));
    quads.push((&LIGHT, light));
    quads.push((&BACK, white));
    quads.push((&GREEN_WALL, green));
    quads.push((&RED_WALL, red));
    quads.extend(SHORT_BLOCK.iter().map(|q| (q, white)));
    quads.extend(TALL_BLOCK.iter().map(|q| (q, white)));
    let mut triangles = Vec::with_capacity(CORNELL_TRIANGLES as usize);
    let mut ids = Vec::with_capacity(CORNELL_TRIANGLES as usize);
    for (q, m) in quads {
        for t in quad_triangles(q) {
            triangles.push(t);
            ids.push(m);
        }
    }
    let camera = Camera {
        eye: EYE,
        direction: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::new(0.0, 0.0, 1.0),
        fov_y_deg: 2.0 * 0.5f32.atan().to_degrees(),
    };
    assemble("cornell", triangles, ids, materials, camera, LIGHT_POSITION)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extents_camera_and_light() {
        let s = cornell();
        assert_eq!(s.triangles.len() as u64, CORNELL_TRIANGLES);
        let b = s.bounds();
        assert_eq!(b.min, Vec3::ZERO);
        assert_eq!(b.max, Vec3::new(556.0, 559.2, 548.8));
        assert!((s.camera.fov_y_deg - 53.130_1).abs() < 1e-3);
        assert!(!b.contains(s.camera.eye));
        assert!(b.contains(s.light.position));
        // The light sits below the ceiling light's centre.
        let lights: Vec<_> = (0..s.triangles.len() as u32)
            .filter(|&i| s.material_of(i).emission != Vec3::ZERO)
            .collect();
        assert_eq!(lights.len(), 2);
        let c = s.triangles[lights[0] as usize];
        assert!(c.iter().all(|v| v.z == 548.8));
        assert!(s.light.position.z < 548.8);
    }

    #[test]
    fn red_wall_is_on_the_left_of_the_camera() {
        let s = cornell();
        let (right, _, _) = s.camera.basis();
        let side = |name: &str| {
            let i = (0..s.triangles.len() as u32)
                .find(|&i| s.material_of(i).name == name)
                .unwrap();
            (s.triangles[i as usize][0] - s.camera.eye).dot(right)
        };
        assert!(side("red") < 0.0 && side("green") > 0.0);
    }

    #[test]
    fn ceiling_and_light_cover_the_ceiling_exactly() {
        let s = cornell();
        let area: f32 = s
            .triangles
            .iter()
            .filter(|t| t.iter().all(|v| v.z == CEILING_Y))
            .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
            .sum();
        assert!((area - CEILING_X * CEILING_Z).abs() < 1.0, "{area}");
    }
}
