//! `rtsim export-triangles`: write the scene's triangles in hit-index order (`tris.bin`,
//! format in `rtsim_scene::export` and docs/SCENES.md), so an external ray caster can rebuild
//! the identical geometry.

use crate::cli::ExportArgs;
use crate::run_config;
use anyhow::{Context, Result};

pub fn run(args: ExportArgs) -> Result<()> {
    let r = run_config::resolve(&args.scene, &[])?;
    let scene = &r.scene;
    rtsim_scene::export::write_triangles_file(&args.out, &scene.triangles)
        .with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!(
        "wrote {} triangles of scene `{}` to {}",
        scene.triangles.len(),
        scene.name,
        args.out.display()
    );
    Ok(())
}
