//! Terrain: placeholder filled in by the terrain work package.
