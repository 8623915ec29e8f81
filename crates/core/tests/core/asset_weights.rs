//! Skin-weight building blocks: the smooth hand-over along a chain and the 4-influence
//! normalization.

use proptest::prelude::*;
use shoal_core::asset::{Influences, chain_blend};

const CHAIN: [(u16, f32); 5] = [(0, 0.1), (1, 0.3), (2, 0.45), (3, 0.7), (4, 0.8)];

fn weights_at(x: f32) -> [f32; 5] {
    let mut w = [0.0; 5];
    chain_blend(&CHAIN, x, 0.35, |j, v| w[usize::from(j)] += v);
    w
}

#[test]
fn chain_blend_hand_values() {
    // Mid-segment: the segment's own (earlier) joint. At a joint: half and half. Before the
    // chain: the first joint.
    assert_eq!(weights_at(0.375), [0.0, 1.0, 0.0, 0.0, 0.0]);
    let at_joint = weights_at(0.3);
    assert!((at_joint[0] - 0.5).abs() < 1e-6 && (at_joint[1] - 0.5).abs() < 1e-6);
    assert_eq!(weights_at(0.0), [1.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(weights_at(1.0), [0.0, 0.0, 0.0, 0.0, 1.0]);
    // Joint 1's blend zone is ±0.35 × min(0.2, 0.15) = ±0.0525 around 0.3.
    assert_eq!(weights_at(0.3 + 0.0525 + 1e-4)[1], 1.0);
    assert!(weights_at(0.3 + 0.04)[1] < 1.0);
}

proptest! {
    #[test]
    fn chain_blend_sums_to_one_and_is_continuous(x in -0.2f32..1.2) {
        let w = weights_at(x);
        prop_assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        prop_assert!(w.iter().filter(|v| **v > 0.0).count() <= 2);
        let v = weights_at(x + 1e-4);
        for k in 0..5 {
            prop_assert!((w[k] - v[k]).abs() < 0.02, "jump at {x}: {w:?} → {v:?}");
        }
    }

    #[test]
    fn influences_keep_four_strongest_summing_to_one(
        pairs in proptest::collection::vec((0u16..12, 0.0f32..1.0), 0..10)
    ) {
        let inf = Influences::from_pairs(&pairs, 3);
        let sum: f32 = inf.weights.iter().sum();
        prop_assert_eq!(sum, 1.0);
        prop_assert!(inf.weights.windows(2).all(|w| w[0] >= w[1] || w[1] == 0.0));
        // Nonzero weights name distinct joints.
        let used: Vec<u16> = (0..4).filter(|&k| inf.weights[k] > 0.0).map(|k| inf.joints[k]).collect();
        let mut dedup = used.clone();
        dedup.sort();
        dedup.dedup();
        prop_assert_eq!(dedup.len(), used.len());
        // Unused slots are joint 0 with weight 0.
        for k in 0..4 {
            if inf.weights[k] == 0.0 {
                prop_assert_eq!(inf.joints[k], 0);
            }
        }
        if pairs.iter().all(|p| p.1 <= 0.0) {
            prop_assert_eq!(inf.joints[0], 3);
        }
    }
}
