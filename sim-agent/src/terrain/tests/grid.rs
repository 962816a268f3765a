use crate::terrain::Terrain;
use crate::Vec2;

#[test]
fn paper_defaults() {
    let t = Terrain::paper();
    assert_eq!((t.width(), t.height()), (60, 60));
    assert_eq!(t.start(), Vec2::new(15.5, 15.5));
    assert_eq!(t.goal(), Vec2::new(44.5, 44.5));
    assert_eq!(t.blocked_count(), 0);
}

#[test]
fn small_defaults_use_integer_division() {
    let t = Terrain::new(10, 7);
    assert_eq!(t.start(), Vec2::new(2.5, 1.5));
    assert_eq!(t.goal(), Vec2::new(7.5, 5.5));
}

#[test]
fn blocked_at_covers_half_open_cells_and_the_outside() {
    let mut t = Terrain::new(4, 3);
    t.set_blocked(2, 1, true);
    assert!(t.cell_blocked(2, 1));
    assert!(!t.cell_blocked(1, 2));
    assert!(t.cell_blocked(4, 0), "outside the grid is impassable");
    assert!(t.is_blocked_at(Vec2::new(2.0, 1.0)));
    assert!(t.is_blocked_at(Vec2::new(2.999, 1.999)));
    assert!(!t.is_blocked_at(Vec2::new(3.0, 1.5)));
    assert!(!t.is_blocked_at(Vec2::new(1.999, 1.5)));
    assert!(!t.is_blocked_at(Vec2::new(0.0, 0.0)));
    for p in [(-0.001, 1.0), (1.0, -0.001), (4.0, 1.0), (1.0, 3.0), (f64::NAN, 1.0), (1e300, 1.0)] {
        assert!(t.is_blocked_at(Vec2::new(p.0, p.1)), "{p:?}");
    }
    assert_eq!(t.blocked_count(), 1);
    t.set_blocked(2, 1, false);
    assert_eq!(t.blocked_count(), 0);
}

#[test]
fn equality_sees_cells_and_points() {
    let a = Terrain::paper();
    let mut b = a.clone();
    assert_eq!(a, b);
    b.set_goal(Vec2::new(40.5, 44.5));
    assert_ne!(a, b);
    let mut c = a.clone();
    c.set_blocked(0, 0, true);
    assert_ne!(a, c);
}
