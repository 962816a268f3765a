//! Terrain text format: any text either is rejected with a `ParseError`
//! (whose line and column lie inside the text) or gives a terrain that
//! `to_text` writes back and that parses to the same terrain.
#![no_main]

use bycoms_sim::terrain::{parse, to_text};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match parse(text) {
        Ok(terrain) => {
            let written = to_text(&terrain);
            let back = parse(&written).expect("to_text output parses");
            assert_eq!((back.width(), back.height()), (terrain.width(), terrain.height()), "size");
            assert_eq!(back.blocked_cells(), terrain.blocked_cells(), "cells");
            assert_eq!((back.start(), back.goal()), (terrain.start(), terrain.goal()), "start and goal");
            assert_eq!(to_text(&back), written, "to_text is stable");
        }
        Err(e) => {
            let lines = text.split('\n').count().max(1);
            assert!(e.line >= 1 && e.line <= lines, "error line {} of {lines}: {e}", e.line);
            assert!(e.column >= 1, "column is 1-based: {e}");
        }
    }
});
