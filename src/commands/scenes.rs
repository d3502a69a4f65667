//! `rtsim scenes`: the built-in and descriptor scenes, with their kind, triangle count (known
//! without loading), whether their files are in the scene directory, and a description.

use super::thousands;
use crate::cli::ScenesArgs;
use anyhow::Result;
use std::io::Write;

pub fn run(args: ScenesArgs) -> Result<()> {
    let dir = rtsim_scene::resolve_scene_dir(args.scene_dir.as_deref());
    let list = rtsim_scene::list_scenes(dir.as_deref());
    let rows: Vec<[String; 5]> = list
        .iter()
        .map(|s| {
            let files = match (s.kind, s.available) {
                ("built-in", _) => "-".to_string(),
                (_, true) => "present".to_string(),
                (_, false) => "missing".to_string(),
            };
            [
                s.name.clone(),
                s.kind.to_string(),
                s.triangles.map(thousands).unwrap_or_else(|| "?".into()),
                files,
                s.description.clone(),
            ]
        })
        .collect();
    let header = ["NAME", "KIND", "TRIANGLES", "FILES", "DESCRIPTION"].map(String::from);
    let mut width = [0usize; 4];
    for r in std::iter::once(&header).chain(&rows) {
        for (w, c) in width.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let mut out = String::new();
    for r in std::iter::once(&header).chain(&rows) {
        // Left-aligned text, right-aligned counts.
        out.push_str(&format!(
            "{:<w0$}  {:<w1$}  {:>w2$}  {:<w3$}  {}\n",
            r[0],
            r[1],
            r[2],
            r[3],
            r[4],
            w0 = width[0],
            w1 = width[1],
            w2 = width[2],
            w3 = width[3],
        ));
    }
    out.push_str(&match &dir {
        Some(d) => format!(
            "\nscene directory: {} (from --scene-dir, $RTSIM_SCENE_DIR or ../shared/scenes)\n",
            d.display()
        ),
        None => "\nscene directory: none (set --scene-dir or RTSIM_SCENE_DIR; ../shared/scenes does not exist)\n"
            .to_string(),
    });
    out.push_str(
        "built-in counts are at scene.size = 1; any other --scene may be a .toml descriptor or \
         an .obj/.ply mesh (see docs/SCENES.md)\n",
    );
    match std::io::stdout().lock().write_all(out.as_bytes()) {
        // `rtsim scenes | head` closing the pipe early is not an error.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => Ok(r?),
    }
}

#[cfg(test)]
mod tests {
    use super::thousands;

    #[test]
    fn thousands_separators() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(2_880_000), "2,880,000");
    }
}
