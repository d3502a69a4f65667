//! Errors of building and running the SGRT model.

use rtsim_cache::HierarchyError;
use rtsim_config::ConfigError;
use rtsim_sim::LinkError;
use rtsim_trace::query::QueryError;

/// Why an SGRT run could not be built or did not finish.
#[derive(Debug, thiserror::Error)]
pub enum SgrtError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("SGRT memory path: {0}")]
    Hierarchy(#[from] HierarchyError),
    #[error("SGRT buffer: {0}")]
    Link(#[from] LinkError),
    #[error(transparent)]
    Rays(#[from] QueryError),
    /// The scene has no BVH to traverse.
    #[error("the scene has no triangles: nothing to traverse")]
    EmptyScene,
    /// A model invariant broke (a bug in rtsim, reported with the state that shows it).
    #[error("SGRT model stalled at cycle {cycle}: {detail} (a bug in rtsim, please report it)")]
    Stalled { cycle: u64, detail: String },
}
