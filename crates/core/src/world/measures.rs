//! Measures of a school, as fish biologists take them: how aligned it swims and how closely its
//! fish keep. `shoal compare` samples them, and behaviour tests read them (`w:polarization`).

use glam::Vec3;

/// |mean of unit horizontal heading vectors|: 1 when all fish face the same way, near 0 when
/// headings are spread evenly.
pub fn polarization(headings: impl Iterator<Item = f32>) -> f64 {
    let (mut sx, mut sz, mut n) = (0f64, 0f64, 0usize);
    for h in headings {
        sx += f64::from(h.cos());
        sz += f64::from(h.sin());
        n += 1;
    }
    if n == 0 {
        return 0.0;
    }
    (sx * sx + sz * sz).sqrt() / n as f64
}

/// (mean, minimum) over points of the distance to each point's nearest other point; (0, 0) with
/// fewer than two points.
pub fn nearest_distances(points: &[Vec3]) -> (f64, f64) {
    if points.len() < 2 {
        return (0.0, 0.0);
    }
    let mut sum = 0f64;
    let mut min = f64::INFINITY;
    for (i, p) in points.iter().enumerate() {
        let nearest = points
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, q)| f64::from(p.distance(*q)))
            .fold(f64::INFINITY, f64::min);
        sum += nearest;
        min = min.min(nearest);
    }
    (sum / points.len() as f64, min)
}
