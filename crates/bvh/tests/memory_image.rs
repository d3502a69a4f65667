//! The memory image: addresses unique, non-overlapping, aligned and in range; sibling pairs
//! per line; parent pointers; node orders; byte encoding; table placements.

mod support;

use rtsim_bvh::memory::{NO_MATERIAL, NO_TREELET, decode_node};
use rtsim_bvh::{
    Bvh, BvhConfig, ImageParts, MemoryImage, MemoryImageError, MemoryLayoutConfig, NO_PARENT,
    NodeOrder, Placement, Region, build,
};
use support::*;

fn scene() -> (Vec<Tri>, Bvh) {
    let mut t = random_soup(4000, 8, 0.05);
    t.extend(sphere(20, 30));
    let bvh = build(&t, &BvhConfig::default(), NodeOrder::DepthFirst).unwrap();
    (t, bvh)
}

fn layouts() -> Vec<MemoryLayoutConfig> {
    let d = MemoryLayoutConfig::default();
    vec![
        d.clone(),
        MemoryLayoutConfig {
            parent_pointers: true,
            ..d.clone()
        },
        MemoryLayoutConfig {
            parent_pointers: true,
            node_bytes: Some(64),
            triangle_bytes: 48,
            base_address: 3 << 20,
            region_alignment: 4096,
            align_sibling_pairs: false,
            ..d.clone()
        },
        MemoryLayoutConfig {
            triangle_bytes: 36,
            region_alignment: 64,
            ..d
        },
    ]
}

#[test]
fn records_are_unique_aligned_in_range_and_disjoint() {
    let (_, bvh) = scene();
    for cfg in layouts() {
        let img = MemoryImage::new(&bvh, &cfg).unwrap();
        img.check().unwrap();
        let nodes = img.region("nodes").unwrap().clone();
        let tris = img.region("triangles").unwrap().clone();
        assert_eq!(nodes.base, cfg.base_address);
        assert_eq!(tris.base % cfg.region_alignment, 0);
        assert!(nodes.end() <= tris.base);
        let nb = cfg.resolved_node_bytes() as u64;
        let pad = if cfg.align_sibling_pairs { nb } else { 0 };
        for i in 0..bvh.nodes.len() as u32 {
            let a = img.node_addr(i);
            assert_eq!(a, nodes.base + pad + i as u64 * nb);
            assert!(a % 4 == 0 && nodes.contains(a, nb));
        }
        let tb = cfg.triangle_bytes as u64;
        for s in 0..bvh.prim_ids.len() as u32 {
            let a = img.triangle_addr(s);
            assert_eq!(a, tris.base + s as u64 * tb);
            assert!(tris.contains(a, tb));
        }
        let (lo, hi) = img.span();
        assert_eq!((lo, hi), (nodes.base, tris.end()));
    }
}

#[test]
fn each_sibling_pair_is_one_line_with_32_byte_nodes() {
    let (_, bvh) = scene();
    let aligned = MemoryImage::new(&bvh, &MemoryLayoutConfig::default()).unwrap();
    let unaligned = MemoryImage::new(
        &bvh,
        &MemoryLayoutConfig {
            align_sibling_pairs: false,
            ..Default::default()
        },
    )
    .unwrap();
    let mut split_pairs = 0;
    for n in bvh.nodes.iter().filter(|n| !n.is_leaf()) {
        let (a, b) = (
            aligned.node_lines(n.index, 64),
            aligned.node_lines(n.index + 1, 64),
        );
        assert_eq!((a.count, b.count), (1, 1));
        assert_eq!(a.first, b.first, "pair at {} spans two lines", n.index);
        assert_eq!(aligned.node_addr(n.index) % 64, 0);
        let (a, b) = (
            unaligned.node_lines(n.index, 64),
            unaligned.node_lines(n.index + 1, 64),
        );
        split_pairs += (a.first != b.first) as usize;
    }
    // Without the padding record every pair (at odd indices) straddles two lines.
    assert_eq!(split_pairs, bvh.nodes.len() / 2);
}

#[test]
fn triangle_fetches_straddle_lines_as_computed_by_hand() {
    let (_, bvh) = scene();
    let img = MemoryImage::new(&bvh, &MemoryLayoutConfig::default()).unwrap();
    // 44-byte records from a line-aligned base: offsets 44k mod 64 for k = 0..16 are
    // 0,44,24,4,48,28,8,52,32,12,56,36,16,60,40,20; ten of them exceed 20 and straddle.
    let lines: u32 = (0..16).map(|s| img.triangle_lines(s, 64).count).sum();
    assert_eq!(lines, 26);
    // With 40-byte parent-pointer node records a node fetch covers 40 bytes.
    let pp = MemoryImage::new(
        &bvh,
        &MemoryLayoutConfig {
            parent_pointers: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!((pp.node_bytes(), pp.node_data_bytes()), (40, 40));
    // Node 1 at 2 × 40 = 80: bytes 80..120, one line; node 2 at 120..160 straddles.
    assert_eq!(pp.node_lines(1, 64).count, 1);
    assert_eq!(pp.node_lines(2, 64).count, 2);
}

#[test]
fn parent_pointers_are_correct() {
    let (_, bvh) = scene();
    let plain = MemoryImage::new(&bvh, &MemoryLayoutConfig::default()).unwrap();
    assert!(plain.parents().is_none() && plain.parent(1).is_none());
    let img = MemoryImage::new(
        &bvh,
        &MemoryLayoutConfig {
            parent_pointers: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(img.parent(0), None);
    let mut seen = 0;
    for (i, n) in bvh.nodes.iter().enumerate() {
        if !n.is_leaf() {
            assert_eq!(img.parent(n.index), Some(i as u32));
            assert_eq!(img.parent(n.index + 1), Some(i as u32));
            seen += 2;
        }
    }
    assert_eq!(seen + 1, bvh.nodes.len());
}

#[test]
fn memory_order_follows_the_node_order() {
    let (t, _) = scene();
    let c = BvhConfig::default();
    let bfs = build(&t, &c, NodeOrder::BreadthFirst).unwrap();
    let img = MemoryImage::new(&bfs, &MemoryLayoutConfig::default()).unwrap();
    // Breadth-first: addresses never decrease with depth, so each level is one contiguous
    // address range.
    let depth = bfs.depths();
    let mut by_addr: Vec<(u64, u32)> = (0..bfs.nodes.len() as u32)
        .map(|i| (img.node_addr(i), depth[i as usize]))
        .collect();
    by_addr.sort();
    assert!(by_addr.windows(2).all(|w| w[0].1 <= w[1].1));
    // Depth-first: each subtree's pairs come after its parent's pair, so a child's address
    // exceeds its parent's.
    let dfs = build(&t, &c, NodeOrder::DepthFirst).unwrap();
    let img = MemoryImage::new(&dfs, &MemoryLayoutConfig::default()).unwrap();
    for (i, n) in dfs.nodes.iter().enumerate().filter(|(_, n)| !n.is_leaf()) {
        assert!(img.node_addr(n.index) > img.node_addr(i as u32));
    }
}

#[test]
fn encoded_bytes_decode_to_the_bvh() {
    let (t, bvh) = scene();
    let mats: Vec<u32> = (0..t.len() as u32).map(|i| i % 7).collect();
    for cfg in layouts() {
        let img = MemoryImage::new(&bvh, &cfg).unwrap();
        let regions = img.encode(&bvh, &t, Some(&mats)).unwrap();
        let bytes = |addr: u64, len: u32| -> &[u8] {
            let r = regions
                .iter()
                .find(|r| r.region.contains(addr, len as u64))
                .unwrap();
            &r.bytes[(addr - r.region.base) as usize..][..len as usize]
        };
        let u32_at = |b: &[u8], k: usize| u32::from_le_bytes(b[k..k + 4].try_into().unwrap());
        let parents = bvh.parents();
        for (i, n) in bvh.nodes.iter().enumerate() {
            let rec = bytes(img.node_addr(i as u32), img.node_bytes());
            assert_eq!(decode_node(rec), Some(*n));
            if cfg.parent_pointers {
                assert_eq!(u32_at(rec, 32), parents[i]);
                assert_eq!(u32_at(rec, 36), NO_TREELET);
            }
            assert!(
                rec[img.node_data_bytes() as usize..]
                    .iter()
                    .all(|&b| b == 0)
            );
        }
        assert_eq!(parents[0], NO_PARENT);
        for (slot, &id) in bvh.prim_ids.iter().enumerate() {
            let rec = bytes(img.triangle_addr(slot as u32), img.triangle_bytes());
            for (v, vert) in t[id as usize].iter().enumerate() {
                for (c, x) in vert.to_array().into_iter().enumerate() {
                    let k = 12 * v + 4 * c;
                    assert_eq!(f32::from_le_bytes(rec[k..k + 4].try_into().unwrap()), x);
                }
            }
            if cfg.triangle_bytes >= 44 {
                assert_eq!((u32_at(rec, 36), u32_at(rec, 40)), (id, id % 7));
            }
        }
        // Without materials the id word says so.
        let no_mat = img.encode(&bvh, &t, None).unwrap();
        if cfg.triangle_bytes >= 44 {
            let a = img.triangle_addr(0);
            let r = no_mat.iter().find(|r| r.region.contains(a, 44)).unwrap();
            let off = (a - r.region.base) as usize;
            assert_eq!(u32_at(&r.bytes[off..], 40), NO_MATERIAL);
        }
    }
    // Mismatched inputs are an error, not a panic.
    let img = MemoryImage::new(&bvh, &MemoryLayoutConfig::default()).unwrap();
    assert!(img.encode(&bvh, &t[..10], None).is_err());
}

fn parts_for(bvh: &Bvh) -> ImageParts {
    MemoryImage::new(bvh, &MemoryLayoutConfig::default())
        .unwrap()
        .parts()
        .clone()
}

#[test]
fn table_placements_are_checked() {
    let (_, bvh) = scene();
    let n = bvh.nodes.len() as u32;
    // A valid permutation: nodes in reverse order within the node region.
    let mut p = parts_for(&bvh);
    let base = p.regions[0].base + 32;
    p.nodes = Placement::Table((0..n).map(|i| base + (n - 1 - i) as u64 * 32).collect());
    let img = MemoryImage::from_parts(p.clone()).unwrap();
    assert_eq!(img.node_addr(0), base + (n - 1) as u64 * 32);

    let expect_layout_err = |p: ImageParts, what: &str| match MemoryImage::from_parts(p) {
        Err(MemoryImageError::Layout(m)) => assert!(m.contains(what), "{m}"),
        other => panic!("expected a layout error about {what}, got {other:?}"),
    };
    let mut q = p.clone();
    if let Placement::Table(t) = &mut q.nodes {
        t[5] = t[6] + 8; // overlaps node 6
    }
    expect_layout_err(q, "overlaps");
    let mut q = p.clone();
    if let Placement::Table(t) = &mut q.nodes {
        t[3] += 2;
    }
    expect_layout_err(q, "aligned");
    let mut q = p.clone();
    if let Placement::Table(t) = &mut q.nodes {
        t[0] = 1 << 40;
    }
    expect_layout_err(q, "outside");
    let mut q = p.clone();
    q.nodes = Placement::Table(vec![0; 3]);
    expect_layout_err(q, "entries");
    let mut q = p.clone();
    q.regions.push(Region {
        name: "extra".into(),
        base: q.regions[1].base + 4,
        size_bytes: 8,
    });
    expect_layout_err(q, "overlap");
}

#[test]
fn empty_bvh_and_overflow() {
    let img = MemoryImage::new(&Bvh::default(), &MemoryLayoutConfig::default()).unwrap();
    img.check().unwrap();
    assert_eq!(img.regions().iter().map(|r| r.size_bytes).sum::<u64>(), 0);
    let (_, bvh) = scene();
    let top = MemoryLayoutConfig {
        base_address: u64::MAX / 8192 * 8192,
        ..Default::default()
    };
    match MemoryImage::new(&bvh, &top) {
        Err(e @ MemoryImageError::AddressOverflow { .. }) => {
            assert!(e.to_string().contains("memory.base_address"))
        }
        other => panic!("{other:?}"),
    }
    let bad = MemoryLayoutConfig {
        triangle_bytes: 30,
        ..Default::default()
    };
    let e = MemoryImage::new(&bvh, &bad).unwrap_err().to_string();
    assert!(
        e.contains("memory.triangle_bytes") && e.contains("36..=256"),
        "{e}"
    );
}
