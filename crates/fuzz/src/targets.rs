//! The fuzz targets: each feeds bytes to one real parser and lets it answer (a value or an
//! error); a panic, a hang or an oversized allocation is the failure the harness looks for.

use rtsim_core::Affine;
use rtsim_scene::mesh::{self, Compression};
use std::io::Cursor;
use std::path::{Path, PathBuf};

/// One parser or input format under fuzzing.
#[derive(Debug)]
pub struct Target {
    /// Directory name under `corpus/` and `regressions/`.
    pub name: &'static str,
    pub about: &'static str,
    /// Parse `input`; must return (any result) without panicking.
    pub run: fn(&[u8]),
    /// Tokens the mutator splices in (keywords of the format).
    pub dict: &'static [&'static [u8]],
    /// Whether the format is binary (the mutator then also overwrites aligned words).
    pub binary: bool,
}

/// Every target, in the order the runner visits them.
pub const TARGETS: &[Target] = &[
    Target {
        name: "obj",
        about: "Wavefront OBJ meshes",
        run: obj,
        dict: &[
            b"v ", b"f ", b"vt ", b"vn ", b"usemtl ", b"mtllib ", b"o ", b"g ", b"/", b"//",
            b"\\\n", b"#",
        ],
        binary: false,
    },
    Target {
        name: "mtl",
        about: "MTL material libraries",
        run: mtl,
        dict: &[
            b"newmtl ",
            b"Kd ",
            b"Ke ",
            b"spectral ",
            b"xyz ",
            b"Ns ",
            b"#",
        ],
        binary: false,
    },
    Target {
        name: "ply",
        about: "PLY meshes (ascii, binary little- and big-endian)",
        run: ply,
        dict: &[
            b"element ",
            b"property ",
            b"list ",
            b"uchar ",
            b"int ",
            b"float ",
            b"double ",
            b"vertex ",
            b"face ",
            b"vertex_indices",
            b"end_header\n",
            b"format ascii 1.0\n",
            b"format binary_big_endian 1.0\n",
            b"comment ",
            b"4611686018427387904",
        ],
        binary: true,
    },
    Target {
        name: "obj-gz",
        about: "gzip-compressed OBJ (the compressed stream is mutated)",
        run: obj_gz,
        dict: &[b"\x1f\x8b\x08\x00", b"\x00\x00\x00\x00"],
        binary: true,
    },
    Target {
        name: "ply-zst",
        about: "zstd-compressed PLY (the compressed stream is mutated)",
        run: ply_zst,
        dict: &[b"\x28\xb5\x2f\xfd", b"\x00\x00\x00\x00"],
        binary: true,
    },
    Target {
        name: "descriptor",
        about: "TOML scene descriptors (parsed, validated, built without mesh files)",
        run: descriptor,
        dict: &[
            b"[[mesh]]\n",
            b"[camera]\n",
            b"[light]\n",
            b"[box]\n",
            b"[workload]\n",
            b"file = ",
            b"scale = ",
            b"rotate = ",
            b"look_at = ",
            b"fov_y = ",
            b"min = ",
            b"max = ",
            b"3e38",
        ],
        binary: false,
    },
    Target {
        name: "run-config",
        about: "run configurations (`--config FILE` of render/simulate/trace)",
        run: run_config,
        dict: &[
            b"[bvh]\n",
            b"[trace]\n",
            b"[workload]\n",
            b"[dram]\n",
            b"[arch]\n",
            b"[sim]\n",
            b"threads = ",
            b"seed = ",
            b"width = ",
            b"preset = ",
            b"9223372036854775807",
        ],
        binary: false,
    },
    Target {
        name: "dram-config",
        about: "DRAM configurations (`rtsim dram --config FILE`)",
        run: dram_config,
        dict: &[
            b"[timing]\n",
            b"[organisation]\n",
            b"[controller]\n",
            b"[dram]\n",
            b"clock_mhz = ",
            b"preset = ",
            b"tRCD = ",
            b"channels = ",
        ],
        binary: false,
    },
    Target {
        name: "dram-trace-rtsim",
        about: "DRAM traces, rtsim format",
        run: dram_trace_rtsim,
        dict: &[b" R ", b" W ", b"0x", b"281474976710656"],
        binary: false,
    },
    Target {
        name: "dram-trace-dramsim3",
        about: "DRAM traces, DRAMsim3 format",
        run: dram_trace_dramsim3,
        dict: &[b" READ ", b" WRITE ", b"0x"],
        binary: false,
    },
    Target {
        name: "dram-trace-usimm",
        about: "DRAM traces, USIMM format",
        run: dram_trace_usimm,
        dict: &[b" R ", b" W ", b"0x", b"4294967296"],
        binary: false,
    },
    Target {
        name: "cache-trace",
        about: "address traces of `rtsim cache`",
        run: cache_trace,
        dict: &[b"R ", b"W ", b"LOAD ", b"STORE ", b"0x", b"#"],
        binary: false,
    },
    Target {
        name: "rays",
        about: "`rays.bin` ray queries",
        run: rays,
        dict: &[
            b"\x00\x00\xc0\x7f",
            b"\x00\x00\x80\x7f",
            b"\xff\xff\xff\xff\xff\xff\xff\xff",
        ],
        binary: true,
    },
    Target {
        name: "tris",
        about: "`tris.bin` triangle files",
        run: tris,
        dict: &[b"\x00\x00\xc0\x7f", b"\xff\xff\xff\xff\xff\xff\xff\x0f"],
        binary: true,
    },
];

/// A path that names the input in errors and holds no files beside it (so `mtllib` finds
/// nothing and descriptor meshes are missing).
fn nowhere(name: &str) -> PathBuf {
    Path::new("/nonexistent-rtsim-fuzz").join(name)
}

fn obj(input: &[u8]) {
    let p = nowhere("f.obj");
    if let Ok(m) = mesh::obj::parse_obj(Cursor::new(input.to_vec()), &p) {
        let _ = mesh::check_extent(&m.into_mesh(&Affine::IDENTITY), &p);
    }
}

fn mtl(input: &[u8]) {
    let mut report = rtsim_scene::LoadReport::default();
    let _ = mesh::mtl::parse_mtl(Cursor::new(input.to_vec()), &nowhere("f.mtl"), &mut report);
}

fn ply(input: &[u8]) {
    let p = nowhere("f.ply");
    let len = Some(input.len() as u64);
    if let Ok(m) = mesh::ply::parse_ply_sized(Cursor::new(input.to_vec()), &p, len) {
        let _ = mesh::check_extent(&m.into_mesh(&Affine::IDENTITY), &p);
    }
}

fn obj_gz(input: &[u8]) {
    if let Ok(r) = mesh::decompress(Cursor::new(input.to_vec()), Compression::Gzip) {
        let _ = mesh::obj::parse_obj(r, &nowhere("f.obj.gz"));
    }
}

fn ply_zst(input: &[u8]) {
    if let Ok(r) = mesh::decompress(Cursor::new(input.to_vec()), Compression::Zstd) {
        let _ = mesh::ply::parse_ply(r, &nowhere("f.ply.zst"));
    }
}

fn descriptor(input: &[u8]) {
    let Ok(text) = std::str::from_utf8(input) else {
        return;
    };
    let p = nowhere("d.toml");
    if let Ok(d) = rtsim_scene::descriptor::Descriptor::parse(text, &p) {
        let _ = d.build("fuzz", Path::new("/nonexistent-rtsim-fuzz"));
    }
}

/// `input` as a file in this process's scratch directory (configs are read from files).
fn scratch_file(name: &str, input: &[u8]) -> Option<PathBuf> {
    let dir = std::env::temp_dir().join(format!("rtsim-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    let p = dir.join(name);
    std::fs::write(&p, input).ok()?;
    Some(p)
}

fn run_config(input: &[u8]) {
    let Some(p) = scratch_file("run.toml", input) else {
        return;
    };
    let inputs = rtsim_run::Inputs {
        config_file: Some(p),
        ..Default::default()
    };
    if let Ok(l) = rtsim_run::layers(&inputs, None) {
        let _ = l.build::<rtsim_run::RunConfig>();
    }
}

fn dram_config(input: &[u8]) {
    let Some(p) = scratch_file("dram.toml", input) else {
        return;
    };
    let _ = rtsim_dram::config::resolve(&rtsim_dram::config::UserLayers {
        preset: None,
        file: Some(&p),
        sets: &[],
    });
}

fn dram_trace(input: &[u8], format: rtsim_dram::trace::TraceFormat) {
    let r = rtsim_dram::trace::TraceReader::new(Cursor::new(input), &nowhere("t.trc"), format);
    for rec in r {
        if rec.is_err() {
            break;
        }
    }
}

fn dram_trace_rtsim(input: &[u8]) {
    dram_trace(input, rtsim_dram::trace::TraceFormat::Rtsim);
}

fn dram_trace_dramsim3(input: &[u8]) {
    dram_trace(input, rtsim_dram::trace::TraceFormat::Dramsim3);
}

fn dram_trace_usimm(input: &[u8]) {
    dram_trace(input, rtsim_dram::trace::TraceFormat::Usimm);
}

fn cache_trace(input: &[u8]) {
    let r = rtsim_cache::trace::TraceReader::new(Cursor::new(input), &nowhere("c.trc"));
    for a in r {
        if a.is_err() {
            break;
        }
    }
}

fn rays(input: &[u8]) {
    let Ok(mut r) = rtsim_trace::query::RayReader::from_bytes(input.to_vec(), &nowhere("r.bin"))
    else {
        return;
    };
    let mut chunk = Vec::new();
    while let Ok(n) = r.read_chunk(1024, &mut chunk) {
        if n == 0 {
            break;
        }
    }
}

fn tris(input: &[u8]) {
    let _ = rtsim_scene::export::read_triangles(input);
}
