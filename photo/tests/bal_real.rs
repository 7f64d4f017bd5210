//! The BAL problems of the shared data: final cost against the reference solver's.

use photo::bal::{solve, BalProblem, LmOptions};
use testkit::shared_data as data;

#[test]
fn ladybug_49_cameras_reach_the_reference_cost() {
    for (file, bound) in [
        (
            "photo/bal/bal-ladybug-problem-49-7776-pre-shrink-1800.txt",
            3.0044e3,
        ),
        ("photo/bal/problem-49-7776-pre.txt", 1.3358e4),
    ] {
        let Some(p) = data(file) else { return };
        let mut prob = BalProblem::read(&p).unwrap();
        let r = solve(&mut prob, &LmOptions::default()).unwrap();
        eprintln!(
            "{file}: cost {:.6e} → {:.6e} in {} iterations ({} successful), {:.2} s, RMS {:.3} px",
            r.initial_cost, r.final_cost, r.iterations, r.successful, r.seconds, r.rms_px
        );
        assert!(r.final_cost <= bound, "{file}: {}", r.final_cost);
    }
}

/// The sparse path (faer, symbolic factorisation reused) gives the dense path's answer.
#[test]
fn sparse_reduced_system_matches_dense() {
    let Some(p) = data("photo/bal/bal-ladybug-problem-49-7776-pre-shrink-1800.txt") else {
        return;
    };
    let mut dense = BalProblem::read(&p).unwrap();
    let mut sparse = dense.clone();
    let a = solve(&mut dense, &LmOptions::default()).unwrap();
    let b = solve(
        &mut sparse,
        &LmOptions {
            dense_limit: 0,
            ..LmOptions::default()
        },
    )
    .unwrap();
    eprintln!(
        "dense {:.9e} in {} iterations, sparse {:.9e} in {}",
        a.final_cost, a.iterations, b.final_cost, b.iterations
    );
    assert!((a.final_cost - b.final_cost).abs() <= 1e-6 * a.final_cost);
    assert!(b.final_cost <= 3.0044e3);
}
