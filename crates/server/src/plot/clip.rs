//! Holding what is drawn to the plot's rectangle, in pixels. A fixed y
//! range or a guide can put points far outside it, and a chart needs no
//! ids (so no `<clipPath>`): lines are cut where they leave the rectangle
//! and markers outside it are left out.

/// Slack around the rectangle, px: a point on the frame, moved by
/// rounding, is still inside.
const SLACK: f64 = 0.5;

/// A rectangle in pixels, `top` < `bottom`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Rect {
    pub left: f64,
    pub top: f64,
    pub right: f64,
    pub bottom: f64,
}

/// The part of a segment inside a rectangle: its two ends, and whether
/// each is the segment's own end (not a cut).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Kept {
    pub from: (f64, f64),
    pub to: (f64, f64),
    pub from_is_start: bool,
    pub to_is_end: bool,
}

impl Rect {
    /// The rectangle between two pixel ranges, in either order.
    pub fn spanning((x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Rect {
        Rect {
            left: x0.min(x1) - SLACK,
            top: y0.min(y1) - SLACK,
            right: x0.max(x1) + SLACK,
            bottom: y0.max(y1) + SLACK,
        }
    }

    pub fn contains(&self, (x, y): (f64, f64)) -> bool {
        (self.left..=self.right).contains(&x) && (self.top..=self.bottom).contains(&y)
    }

    /// The part of the segment a→b inside the rectangle, if any
    /// (Liang–Barsky: the segment's parameter range narrowed by each edge).
    pub fn clip(&self, a: (f64, f64), b: (f64, f64)) -> Option<Kept> {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let edges = [
            (-dx, a.0 - self.left),
            (dx, self.right - a.0),
            (-dy, a.1 - self.top),
            (dy, self.bottom - a.1),
        ];
        for (p, q) in edges {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
                continue;
            }
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
            if t0 > t1 {
                return None;
            }
        }
        let at = |t: f64| (a.0 + t * dx, a.1 + t * dy);
        Some(Kept {
            from: if t0 == 0.0 { a } else { at(t0) },
            to: if t1 == 1.0 { b } else { at(t1) },
            from_is_start: t0 == 0.0,
            to_is_end: t1 == 1.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Rect {
        Rect::spanning((0.0, 100.0), (100.0, 0.0))
    }

    #[test]
    fn a_segment_inside_is_kept_whole() {
        let k = unit().clip((10.0, 10.0), (90.0, 50.0)).unwrap();
        assert_eq!((k.from, k.to), ((10.0, 10.0), (90.0, 50.0)));
        assert!(k.from_is_start && k.to_is_end);
    }

    #[test]
    fn a_segment_crossing_the_frame_is_cut_where_it_leaves() {
        // From inside to far above: cut at the top edge (−0.5 with slack).
        let k = unit().clip((50.0, 50.0), (50.0, -1e6)).unwrap();
        assert_eq!(k.to, (50.0, -0.5));
        assert!(k.from_is_start && !k.to_is_end);
        // Across the whole plot, both ends cut.
        let k = unit().clip((-100.0, 50.0), (200.0, 50.0)).unwrap();
        assert_eq!((k.from, k.to), ((-0.5, 50.0), (100.5, 50.0)));
        assert!(!k.from_is_start && !k.to_is_end);
    }

    #[test]
    fn a_segment_outside_is_dropped() {
        assert!(unit().clip((-10.0, -10.0), (200.0, -5.0)).is_none());
        assert!(unit().clip((150.0, 10.0), (150.0, 90.0)).is_none());
        assert!(!unit().contains((50.0, 101.0)));
        assert!(unit().contains((100.4, 0.0)));
    }
}
