//! PLACEHOLDER (skeleton): filled in by the scene work.
