//! The spatial grid answers radius queries exactly like a brute-force scan.

use glam::Vec3;
use proptest::prelude::*;
use shoal_core::world::grid::Grid;

fn vec3(lo: f32, hi: f32) -> impl Strategy<Value = Vec3> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random scenes (points partly outside the grid box), random cell sizes and queries.
    #[test]
    fn grid_query_equals_brute_force(
        points in prop::collection::vec(vec3(-20.0, 120.0), 0..300),
        queries in prop::collection::vec((vec3(-30.0, 130.0), 0.0f32..60.0), 1..20),
        cell in 0.5f32..80.0,
    ) {
        let mut grid = Grid::new(Vec3::ZERO, Vec3::splat(100.0), cell);
        grid.rebuild(points.iter().enumerate().map(|(i, &p)| (i as u32, p)));
        prop_assert_eq!(grid.len(), points.len());
        for (centre, radius) in queries {
            let mut got = Vec::new();
            grid.for_each_within(centre, radius, |k, p, d2| {
                assert_eq!(p, points[k as usize]);
                assert_eq!(d2, p.distance_squared(centre));
                got.push(k);
                true
            });
            got.sort_unstable();
            let want: Vec<u32> = points
                .iter()
                .enumerate()
                .filter(|(_, p)| p.distance_squared(centre) <= radius * radius)
                .map(|(i, _)| i as u32)
                .collect();
            prop_assert_eq!(got, want);
        }
    }
}

#[test]
fn rebuilding_twice_gives_the_same_answer_and_a_stopping_visitor_stops() {
    let pts: Vec<Vec3> = (0..100)
        .map(|i| Vec3::new((i % 10) as f32 * 10.0, 50.0, (i / 10) as f32 * 10.0))
        .collect();
    let mut grid = Grid::new(Vec3::ZERO, Vec3::splat(100.0), 15.0);
    let mut first = Vec::new();
    for round in 0..2 {
        grid.rebuild(pts.iter().enumerate().map(|(i, &p)| (i as u32, p)));
        let mut got = Vec::new();
        grid.for_each_within(Vec3::new(45.0, 50.0, 45.0), 15.0, |k, _, _| {
            got.push(k);
            true
        });
        if round == 0 {
            first = got;
        } else {
            assert_eq!(got, first, "same order after a rebuild");
        }
    }
    // (40,40) (50,40) (40,50) (50,50) are 7.07 away; (30,40)... are 15.8 away.
    let mut sorted = first.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, vec![44, 45, 54, 55]);
    let mut seen = 0;
    grid.for_each_within(Vec3::new(45.0, 50.0, 45.0), 15.0, |_, _, _| {
        seen += 1;
        false
    });
    assert_eq!(seen, 1);
}
