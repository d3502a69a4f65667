//! Test helpers: random triangle soups and a simple median-split BVH, so traversal is tested
//! against *any* valid BVH, independently of the SAH builders.

use rtsim_bvh::{Bvh, Node};
use rtsim_core::{Aabb, Pcg32, Ray, Vec3};

pub fn random_soup(n: usize, seed: u64, size: f32) -> Vec<[Vec3; 3]> {
    let mut g = Pcg32::new(seed, 3);
    let mut v = |s: f32| Vec3::new(g.next_f32() - 0.5, g.next_f32() - 0.5, g.next_f32() - 0.5) * s;
    (0..n)
        .map(|_| {
            let c = v(10.0);
            [c + v(size), c + v(size), c + v(size)]
        })
        .collect()
}

pub fn random_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut g = Pcg32::new(seed, 5);
    (0..n)
        .map(|_| {
            let o = Vec3::new(g.next_f32() - 0.5, g.next_f32() - 0.5, g.next_f32() - 0.5) * 14.0;
            let d = Vec3::new(g.next_f32() - 0.5, g.next_f32() - 0.5, g.next_f32() - 0.5);
            let tmax = if g.next_f32() < 0.3 {
                g.next_f32() * 10.0
            } else {
                f32::INFINITY
            };
            Ray::new(o, d, 0.0, tmax)
        })
        .collect()
}

/// Median split on the longest axis of the centroid bounds, `leaf` triangles per leaf.
pub fn median_bvh(tris: &[[Vec3; 3]], leaf: usize) -> Bvh {
    let mut ids: Vec<u32> = (0..tris.len() as u32).collect();
    let mut nodes = Vec::new();
    if tris.is_empty() {
        return Bvh {
            nodes,
            prim_ids: ids,
        };
    }
    let bounds = |ids: &[u32]| {
        ids.iter().fold(Aabb::EMPTY, |b, &i| {
            tris[i as usize].iter().fold(b, |b, &v| b.grown(v))
        })
    };
    nodes.push(Node {
        bounds: bounds(&ids),
        index: 0,
        count: 0,
    });
    // (node index, start, end)
    let mut work = vec![(0usize, 0usize, ids.len())];
    while let Some((ni, s, e)) = work.pop() {
        if e - s <= leaf {
            nodes[ni].index = s as u32;
            nodes[ni].count = (e - s) as u32;
            continue;
        }
        let cb = ids[s..e].iter().fold(Aabb::EMPTY, |b, &i| {
            b.grown(rtsim_bvh::centroid(&tris[i as usize]))
        });
        let axis = cb.extent().max_axis();
        ids[s..e].sort_by(|&a, &b| {
            rtsim_bvh::centroid(&tris[a as usize])[axis]
                .total_cmp(&rtsim_bvh::centroid(&tris[b as usize])[axis])
        });
        let m = (s + e) / 2;
        let li = nodes.len();
        nodes.push(Node {
            bounds: bounds(&ids[s..m]),
            index: 0,
            count: 0,
        });
        nodes.push(Node {
            bounds: bounds(&ids[m..e]),
            index: 0,
            count: 0,
        });
        nodes[ni].index = li as u32;
        work.push((li, s, m));
        work.push((li + 1, m, e));
    }
    Bvh {
        nodes,
        prim_ids: ids,
    }
}
