//! The funnel (string pulling, Mononen's "simple stupid funnel"): the shortest
//! polyline through a corridor's portals, on the ground plane.

use glam::Vec3;

/// Twice the signed area of `abc` on the ground plane (x, z).
fn triarea2(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (ax, az) = (b.x - a.x, b.z - a.z);
    let (bx, bz) = (c.x - a.x, c.z - a.z);
    bx * az - ax * bz
}

fn same(a: Vec3, b: Vec3) -> bool {
    (a.x - b.x).powi(2) + (a.z - b.z).powi(2) < 1e-10
}

/// A portal's ends as (left, right) for a walker coming from `from` (a point
/// inside the polygon it leaves).
pub(crate) fn oriented(from: Vec3, portal: [Vec3; 2]) -> (Vec3, Vec3) {
    let [u, v] = portal;
    if triarea2(from, u, v) <= 0.0 {
        (v, u)
    } else {
        (u, v)
    }
}

/// The shortest path from `start` to `goal` through `portals` (each (left,
/// right), in order).
#[cfg(test)]
pub(crate) fn funnel(start: Vec3, goal: Vec3, portals: &[(Vec3, Vec3)]) -> Vec<Vec3> {
    funnel_passed(start, goal, portals)
        .into_iter()
        .map(|(p, _)| p)
        .collect()
}

/// [`funnel`]'s corners, each with how many portals the path has passed where
/// it stands on it (0 at the start; a corner on portal `k` has passed `k + 1`;
/// the goal has passed them all).
pub(crate) fn funnel_passed(
    start: Vec3,
    goal: Vec3,
    portals: &[(Vec3, Vec3)],
) -> Vec<(Vec3, usize)> {
    let mut all = Vec::with_capacity(portals.len() + 2);
    all.push((start, start));
    all.extend_from_slice(portals);
    all.push((goal, goal));
    let mut points = vec![(start, 0)];
    let (mut apex, mut left, mut right) = (start, start, start);
    let (mut left_i, mut right_i) = (0, 0);
    let mut i = 1;
    while i < all.len() {
        let (l, r) = all[i];
        // Narrow the right side.
        if triarea2(apex, right, r) <= 0.0 {
            if same(apex, right) || triarea2(apex, left, r) > 0.0 {
                right = r;
                right_i = i;
            } else {
                // The right crosses the left: the left corner is on the path.
                apex = left;
                let apex_i = left_i;
                points.push((apex, apex_i));
                (left, right) = (apex, apex);
                (left_i, right_i) = (apex_i, apex_i);
                i = apex_i + 1;
                continue;
            }
        }
        // Narrow the left side.
        if triarea2(apex, left, l) >= 0.0 {
            if same(apex, left) || triarea2(apex, right, l) < 0.0 {
                left = l;
                left_i = i;
            } else {
                apex = right;
                let apex_i = right_i;
                points.push((apex, apex_i));
                (left, right) = (apex, apex);
                (left_i, right_i) = (apex_i, apex_i);
                i = apex_i + 1;
                continue;
            }
        }
        i += 1;
    }
    if points
        .last()
        .is_none_or(|(p, _)| !same(*p, goal) || p.y != goal.y)
    {
        points.push((goal, portals.len()));
    } else if let Some(last) = points.last_mut() {
        last.1 = portals.len();
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f32, z: f32) -> Vec3 {
        Vec3::new(x, 0.0, z)
    }

    /// Portals (left, right) oriented from the previous portal's middle.
    fn corridor(start: Vec3, edges: &[[Vec3; 2]]) -> Vec<(Vec3, Vec3)> {
        let mut from = start;
        edges
            .iter()
            .map(|e| {
                let o = oriented(from, *e);
                from = (e[0] + e[1]) * 0.5;
                o
            })
            .collect()
    }

    #[test]
    fn a_straight_corridor_is_one_segment() {
        let edges: Vec<[Vec3; 2]> = (1..5)
            .map(|i| [p(i as f32, -1.0), p(i as f32, 1.0)])
            .collect();
        let path = funnel(p(0.0, 0.0), p(5.0, 0.5), &corridor(p(0.0, 0.0), &edges));
        assert_eq!(path, vec![p(0.0, 0.0), p(5.0, 0.5)]);
    }

    #[test]
    fn a_corner_is_cut_at_its_inner_point_both_ways() {
        // Along x at z in [0, 1], then up z at x in [4, 5]: the inner corner is
        // (4, 1).
        let edges = [
            [p(2.0, 0.0), p(2.0, 1.0)],
            [p(4.0, 0.0), p(4.0, 1.0)],
            [p(4.0, 1.0), p(5.0, 1.0)],
            [p(4.0, 3.0), p(5.0, 3.0)],
        ];
        let (s, g) = (p(0.5, 0.5), p(4.5, 5.0));
        let path = funnel(s, g, &corridor(s, &edges));
        assert_eq!(path, vec![s, p(4.0, 1.0), g]);
        // The mirror image turns the other way.
        let m = |v: Vec3| Vec3::new(v.x, 0.0, -v.z);
        let edges: Vec<[Vec3; 2]> = edges.iter().map(|e| [m(e[0]), m(e[1])]).collect();
        let path = funnel(m(s), m(g), &corridor(m(s), &edges));
        assert_eq!(path, vec![m(s), p(4.0, -1.0), m(g)]);
    }
}
