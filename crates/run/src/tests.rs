use super::*;

fn inputs(sets: &[&str]) -> Inputs {
    Inputs {
        sets: sets.iter().map(|s| s.to_string()).collect(),
        ..Inputs::default()
    }
}

fn build(sets: &[&str]) -> Result<RunConfig, ConfigError> {
    layers(&inputs(sets), None)?.build()
}

#[test]
fn defaults_resolve_to_the_functional_arch_on_gddr5_trax() {
    let c = build(&[]).unwrap();
    assert_eq!(c.arch.preset, "functional");
    assert_eq!(c.dram.preset, "gddr5-trax");
    assert_eq!(c.dram, rtsim_dram::DramConfig::default());
}

#[test]
fn the_dram_preset_lies_beneath_the_users_layers() {
    let c = build(&["dram.preset=lpddr3-1600"]).unwrap();
    let lp = rtsim_dram::config::preset_config("lpddr3-1600").unwrap();
    assert_eq!(c.dram, lp);
    // A user's key wins over the preset's.
    let c = build(&["dram.preset=lpddr3-1600", "dram.timing.tRCD=99"]).unwrap();
    assert_eq!(c.dram.timing.t_rcd, 99);
    assert_eq!(c.dram.organisation, lp.organisation);
    // The same as the standalone DRAM command's layering.
    let standalone = rtsim_dram::config::resolve(&rtsim_dram::config::UserLayers {
        preset: Some("lpddr3-1600"),
        file: None,
        sets: &["timing.tRCD=99".to_string()],
    })
    .unwrap();
    assert_eq!(c.dram, standalone);
}

#[test]
fn unknown_presets_and_keys_are_named() {
    let e = build(&["arch.preset=warp-drive"]).unwrap_err().to_string();
    assert!(e.contains("warp-drive") && e.contains("functional"), "{e}");
    let e = build(&["dram.preset=ddr9"]).unwrap_err().to_string();
    assert!(e.contains("ddr9") && e.contains("gddr5-trax"), "{e}");
    let e = build(&["dram.timing.tRCD=0"]).unwrap_err().to_string();
    assert!(e.contains("dram.timing.tRCD"), "{e}");
    let e = build(&["arch.colour=red"]).unwrap_err().to_string();
    assert!(e.contains("arch.colour"), "{e}");
}

#[test]
fn bit_stack_builds_a_32_level_bvh_with_parent_pointers_unless_told_otherwise() {
    let c = build(&["trace.traversal=bit-stack"]).unwrap();
    assert_eq!(c.bvh.max_depth, 32);
    assert!(c.memory.parent_pointers);
    let c = build(&["trace.traversal=bit-stack", "bvh.max_depth=20"]).unwrap();
    assert_eq!(c.bvh.max_depth, 20);
    let e = build(&["trace.traversal=bit-stack", "bvh.max_depth=40"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("bvh.max_depth") && e.contains("32"), "{e}");
    let e = build(&["trace.traversal=bit-stack", "memory.parent_pointers=false"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("memory.parent_pointers"), "{e}");
}

#[test]
fn the_resolved_tree_repeats_the_run() {
    let r = resolve(
        &inputs(&["dram.preset=ddr4-3200", "workload.kind=ao"]),
        &mut |_| {},
    )
    .unwrap();
    let text = resolved_toml(&r, "render").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.toml");
    std::fs::write(&path, text).unwrap();
    let again = resolve(
        &Inputs {
            config_file: Some(path),
            ..Inputs::default()
        },
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(again.config, r.config);
}

#[test]
fn sgrt_presets_set_the_traversal_test_builder_and_dram() {
    for (name, cores, org) in [
        ("sgrt", 4, rtsim_sgrt::Organisation::Pptrv),
        ("sgrt-sptrv", 4, rtsim_sgrt::Organisation::Sptrv),
        ("sgrt-1", 1, rtsim_sgrt::Organisation::Pptrv),
    ] {
        let c = build(&[&format!("arch.preset={name}")]).unwrap();
        assert_eq!(c.arch.sgrt.cores, cores, "{name}");
        assert_eq!(c.arch.sgrt.organisation, org, "{name}");
        assert_eq!(c.trace.traversal, Traversal::ShortStack, "{name}");
        assert_eq!(
            c.trace.triangle_test,
            rtsim_trace::TriangleTest::Wald,
            "{name}"
        );
        assert_eq!(c.bvh.builder, rtsim_bvh::Builder::Sweep, "{name}");
        assert_eq!(c.dram.preset, "lpddr3-1600", "{name}");
    }
    // The user's keys win over the preset's, and SGRT keys are validated with their path.
    let c = build(&["arch.preset=sgrt", "arch.sgrt.cores=2"]).unwrap();
    assert_eq!(c.arch.sgrt.cores, 2);
    let e = build(&["arch.preset=sgrt", "arch.sgrt.trv.stacks=0"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("arch.sgrt.trv.stacks"), "{e}");
    let e = build(&["arch.sgrt.warp=1"]).unwrap_err().to_string();
    assert!(e.contains("arch.sgrt.warp"), "{e}");
}

#[test]
fn a_viewpoint_replaces_the_camera_and_an_unknown_one_is_named() {
    // The shared scenes, as the scene crate's tests find them.
    let dir = std::env::var("RTSIM_SCENE_DIR")
        .unwrap_or_else(|_| format!("{}/../../../shared/scenes", env!("CARGO_MANIFEST_DIR")));
    let dir = format!("scene.dir=\"{dir}\"");
    let r = resolve(
        &inputs(&["scene.name=sibenik", "scene.viewpoint=3", &dir]),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(r.scene.camera, r.scene.viewpoints[2]);
    let e = resolve(
        &inputs(&["scene.name=sibenik", "scene.viewpoint=6", &dir]),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.viewpoint") && e.contains("1..=5"), "{e}");
    let e = resolve(&inputs(&["scene.viewpoint=1"]), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("scene.viewpoint") && e.contains("no [[viewpoint]]"),
        "{e}"
    );
}

#[test]
fn the_trax_preset_sets_its_sections_and_validates_the_chip() {
    let c = build(&["arch.preset=trax-baseline"]).unwrap();
    assert!(c.arch.is_trax());
    assert_eq!(c.trace.traversal, rtsim_trace::Traversal::Stack);
    assert_eq!(
        c.trace.triangle_test,
        rtsim_trace::TriangleTest::MollerTrumbore
    );
    assert_eq!(c.dram.preset, "gddr5-trax");
    assert_eq!(c.arch.trax, rtsim_trax::TraxConfig::default());
    let c = build(&["arch.preset=trax-baseline", "arch.trax.tms=4"]).unwrap();
    assert_eq!(c.arch.trax.tms, 4);
    let e = build(&["arch.preset=trax-baseline", "arch.trax.tms=0"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("arch.trax.tms"), "{e}");
    let e = build(&[
        "arch.preset=trax-baseline",
        "arch.trax.units.fp_add.count=0",
    ])
    .unwrap_err()
    .to_string();
    assert!(e.contains("arch.trax.units.fp_add.count"), "{e}");
    let e = build(&["arch.preset=trax-baseline", "trace.traversal=bit-stack"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("trace.traversal"), "{e}");
    let e = build(&["arch.preset=trax-baseline", "arch.trax.warp=1"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("arch.trax.warp"), "{e}");
    // The functional arch does not care which traversal runs.
    build(&["trace.traversal=bit-stack"]).unwrap();
}

#[test]
fn a_set_contradicting_a_flag_is_an_error_naming_both() {
    let mut i = inputs(&["arch.preset=strata"]);
    i.flag("arch.preset", "functional");
    let e = layers(&i, None).unwrap_err().to_string();
    assert!(
        e.contains("--set `arch.preset=strata`") && e.contains("\"functional\""),
        "{e}"
    );
    // The same value twice, or a flag and a set of different keys, are fine.
    let mut i = inputs(&["arch.preset = \"strata\"", "workload.width=8"]);
    i.flag("arch.preset", "strata")
        .flag("workload.height", 8i64);
    let c: RunConfig = layers(&i, None).unwrap().build().unwrap();
    assert_eq!(c.arch.preset, "strata");
}

#[test]
fn every_chip_table_of_arch_is_named_with_its_readers() {
    // A chip table added to `ArchConfig` without an entry in `CHIP_TABLES` would be taken to
    // be read by every preset.
    let t = toml::Table::try_from(arch::ArchConfig::default()).unwrap();
    let tables: Vec<String> = t
        .iter()
        .filter(|(_, v)| v.is_table())
        .map(|(k, _)| format!("arch.{k}"))
        .collect();
    let named: Vec<&str> = arch::CHIP_TABLES
        .iter()
        .map(|(t, _)| *t)
        .filter(|t| t.starts_with("arch."))
        .collect();
    assert_eq!(tables.len(), named.len(), "{tables:?} against {named:?}");
    for t in &tables {
        assert!(named.contains(&t.as_str()), "{t} is not in CHIP_TABLES");
    }
    for (_, readers) in arch::CHIP_TABLES {
        for r in *readers {
            arch::preset(r).unwrap();
        }
    }
    assert!(arch::reads("strata", "arch.trax.tms"));
    assert!(arch::reads("strata", "arch.strata.fill"));
    assert!(!arch::reads("trax-baseline", "arch.strata.fill"));
    assert!(!arch::reads("sgrt", "arch.trax.l2.size_bytes"));
    assert!(!arch::reads("functional", "arch.sgrt.cores"));
    // Only whole table names count: `arch.stratafoo` is no chip table.
    assert!(arch::reads("functional", "arch.stratafoo"));
    assert!(arch::reads("sgrt", "dram.timing.tRCD"));
    assert!(arch::reads("strata", "dram.controller.read_queue"));
    // Every timed chip has main memory; the functional tracer has none.
    assert!(!arch::reads("functional", "dram.timing.tRCD"));
    let timed: Vec<&str> = arch::ARCH_PRESETS
        .iter()
        .map(|p| p.name)
        .filter(|p| *p != "functional")
        .collect();
    let dram = arch::CHIP_TABLES
        .iter()
        .find(|(t, _)| *t == "dram")
        .unwrap();
    assert_eq!(dram.1, timed.as_slice());
}

#[test]
fn settings_the_runs_chip_does_not_read_are_named_with_where_they_were_set() {
    let mut i = inputs(&[
        "arch.strata.fill=static",
        "arch.trax.tms=4",
        "arch.strata.fused=true",
    ]);
    i.flag("arch.preset", "trax-baseline");
    let lines = unread_settings(&i, "trax-baseline").unwrap();
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert_eq!(
        lines[0],
        "--set arch.strata.fill=static: `arch.strata.fill` has no effect: arch.preset = \
         trax-baseline does not read [arch.strata] (read by strata)"
    );
    assert!(unread_settings(&i, "strata").unwrap().is_empty());
    let sgrt = unread_settings(&i, "sgrt").unwrap();
    assert_eq!(sgrt.len(), 2, "{sgrt:?}");
    assert!(
        sgrt[1].contains("read by trax-baseline, strata"),
        "{}",
        sgrt[1]
    );
    // A file's setting is named by its line.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("run.toml");
    // At its default, a setting is not named (a run's resolved file holds every table).
    std::fs::write(&file, "[arch.sgrt]\ncores = 2\norganisation = \"pptrv\"\n").unwrap();
    assert_eq!(arch::ArchConfig::default().sgrt.cores, 4);
    let i = Inputs {
        config_file: Some(file.clone()),
        ..Inputs::default()
    };
    let lines = unread_settings(&i, "strata").unwrap();
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].contains("arch.sgrt.cores"), "{}", lines[0]);
    assert!(
        lines[0].contains(&format!("{}:2", file.display())),
        "{}",
        lines[0]
    );
}
