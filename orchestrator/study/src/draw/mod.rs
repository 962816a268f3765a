//! Pictures as SVG, written by hand.
//!
//! Why not `plotters`: its text layout needs a font backend (system
//! fontconfig through font-kit, or an embedded TTF with ab_glyph), which a
//! fresh machine may not have, and our pictures are a few hundred
//! rectangles, circles and polylines; plain SVG with the viewer's own fonts
//! is smaller, dependency-free and opens in every browser.

pub mod animate;
pub mod budget;
pub mod contour;
pub mod heatmap;
pub mod measurements;
pub mod run;
pub mod snapshot;
pub mod svg;
pub mod timeline;
pub mod trace;
