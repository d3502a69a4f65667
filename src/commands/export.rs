//! `rtsim export-triangles`: write the scene's triangles in hit-index order (`tris.bin`,
//! format in `rtsim_scene::export` and docs/SCENES.md), so an external ray caster can rebuild
//! the identical geometry.

use crate::cli::ExportArgs;
use crate::run_config;
use anyhow::{Context, Result};
use rtsim_core::output::OutputPlan;

pub fn run(args: ExportArgs) -> Result<()> {
    let r = run_config::resolve(&args.scene, &[])?;
    let scene = &r.scene;
    let mut plan = OutputPlan::new();
    plan.file(&args.out);
    super::scene_inputs(&mut plan, &args.scene, &r);
    let mut outputs = plan.prepare()?;
    let mut f = outputs.create(&args.out)?;
    rtsim_scene::export::write_triangles(&mut f, &scene.triangles)
        .with_context(|| format!("writing {}", args.out.display()))?;
    outputs.finish(f)?;
    outputs.commit()?;
    eprintln!(
        "wrote {} triangles of scene `{}` to {}",
        scene.triangles.len(),
        scene.name,
        args.out.display()
    );
    Ok(())
}
