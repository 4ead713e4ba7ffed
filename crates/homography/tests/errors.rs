//! Every `HomographyError` variant, triggered by the configuration it describes.

mod common;

use common::map_points;
use homography::{
    HomographyError, PointSet, RefineOptions, dlt, estimate, normalization_matrix, refine,
};
use nalgebra::{Matrix3, Point2};

fn h_true() -> Matrix3<f64> {
    Matrix3::new(800.0, 20.0, 320.0, -15.0, 790.0, 240.0, 0.08, -0.05, 1.0)
}

fn grid() -> Vec<Point2<f64>> {
    common::board_points(4, 3, 0.25)
}

/// Runs both `dlt` and `estimate` (and `refine` from the true H) and checks they agree.
fn all_fail(object: &[Point2<f64>], image: &[Point2<f64>]) -> HomographyError {
    let e1 = dlt(object, image).unwrap_err();
    let e2 = estimate(object, image, &RefineOptions::default()).unwrap_err();
    assert_eq!(e1, e2);
    e1
}

#[test]
fn too_few_points() {
    let object = &grid()[..3];
    let image = map_points(&h_true(), object);
    assert_eq!(
        all_fail(object, &image),
        HomographyError::TooFewPoints { found: 3 }
    );
    assert_eq!(
        refine(&h_true(), object, &image, &RefineOptions::default()).unwrap_err(),
        HomographyError::TooFewPoints { found: 3 }
    );
    assert_eq!(
        all_fail(&[], &[]),
        HomographyError::TooFewPoints { found: 0 }
    );
}

#[test]
fn length_mismatch() {
    let object = grid();
    let image = map_points(&h_true(), &object[..7]);
    assert_eq!(
        all_fail(&object, &image),
        HomographyError::LengthMismatch {
            object: 12,
            image: 7
        }
    );
}

#[test]
fn non_finite_in_either_set() {
    let object = grid();
    let image = map_points(&h_true(), &object);

    let mut bad = object.clone();
    bad[5].y = f64::NAN;
    assert_eq!(
        all_fail(&bad, &image),
        HomographyError::NonFinite {
            index: 5,
            set: PointSet::Object
        }
    );

    let mut bad = image.clone();
    bad[2].x = f64::NEG_INFINITY;
    assert_eq!(
        all_fail(&object, &bad),
        HomographyError::NonFinite {
            index: 2,
            set: PointSet::Image
        }
    );
    bad[2].x = f64::NAN;
    assert_eq!(
        refine(&h_true(), &object, &bad, &RefineOptions::default()).unwrap_err(),
        HomographyError::NonFinite {
            index: 2,
            set: PointSet::Image
        }
    );
}

#[test]
fn coincident_points() {
    let object = grid();
    let image = map_points(&h_true(), &object);
    let same = vec![Point2::new(0.3, 0.7); object.len()];
    assert_eq!(
        all_fail(&same, &image),
        HomographyError::Coincident {
            set: PointSet::Object
        }
    );
    let same = vec![Point2::new(512.25, 100.1); object.len()];
    assert_eq!(
        all_fail(&object, &same),
        HomographyError::Coincident {
            set: PointSet::Image
        }
    );
    assert_eq!(
        normalization_matrix(&[Point2::origin(); 5]),
        Err(HomographyError::Coincident {
            set: PointSet::Object
        })
    );
}

#[test]
fn collinear_points() {
    // A row of the board: collinear in both sets, reported for the object set first.
    let object: Vec<_> = (0..9).map(|i| Point2::new(0.03 * i as f64, 0.06)).collect();
    let image = map_points(&h_true(), &object);
    assert_eq!(
        all_fail(&object, &image),
        HomographyError::Collinear {
            set: PointSet::Object
        }
    );

    // A full grid seen exactly edge-on: the second row of H is 0.5 * row 1 + 30 * row 3,
    // so every image point lies on the slanted line y = 0.5 x + 30.
    let object = grid();
    let edge_on = Matrix3::new(300.0, 200.0, 10.0, 153.0, 106.0, 35.0, 0.1, 0.2, 1.0);
    let image = map_points(&edge_on, &object);
    assert_eq!(
        all_fail(&object, &image),
        HomographyError::Collinear {
            set: PointSet::Image
        }
    );
    assert_eq!(
        refine(&h_true(), &object, &image, &RefineOptions::default()).unwrap_err(),
        HomographyError::Collinear {
            set: PointSet::Image
        }
    );
}

#[test]
fn rank_deficient_configurations() {
    // Four points, three of them on a line: the DLT system has a two-dimensional null space.
    let object = [
        Point2::new(0.0, 0.0),
        Point2::new(0.1, 0.0),
        Point2::new(0.25, 0.0),
        Point2::new(0.05, 0.2),
    ];
    let image = map_points(&h_true(), &object);
    assert_eq!(
        all_fail(&object, &image),
        HomographyError::RankDeficient { rank: 7 }
    );

    // Four points of which two are the same: only three distinct correspondences (rank 6).
    let object = [
        Point2::new(0.0, 0.0),
        Point2::new(0.2, 0.0),
        Point2::new(0.1, 0.3),
        Point2::new(0.2, 0.0),
    ];
    let image = map_points(&h_true(), &object);
    assert_eq!(
        all_fail(&object, &image),
        HomographyError::RankDeficient { rank: 6 }
    );

    // Many points, but only three distinct ones.
    let distinct = [
        Point2::new(0.0, 0.0),
        Point2::new(0.2, 0.0),
        Point2::new(0.1, 0.3),
    ];
    let object: Vec<_> = (0..10).map(|i| distinct[i % 3]).collect();
    let image = map_points(&h_true(), &object);
    assert_eq!(
        all_fail(&object, &image),
        HomographyError::RankDeficient { rank: 6 }
    );
}

#[test]
fn plane_origin_mapped_to_infinity() {
    // H33 = 0 exactly: the origin of the plane lies on the vanishing line, while the board
    // (X, Y in 1..2) is well in front (w' = 0.3 X + 0.2 Y > 0).
    let h_inf = Matrix3::new(500.0, 30.0, 100.0, -20.0, 480.0, 50.0, 0.3, 0.2, 0.0);
    let object: Vec<_> = common::board_points(4, 3, 0.25)
        .iter()
        .map(|p| Point2::new(1.0 + p.x, 1.0 + p.y))
        .collect();
    let image = map_points(&h_inf, &object);
    let err = all_fail(&object, &image);
    assert!(
        matches!(err, HomographyError::DegenerateSolution { .. }),
        "{err:?}"
    );

    // `refine` rejects such a starting point too, as well as a non-finite one.
    let grid = grid();
    let image = map_points(&h_true(), &grid);
    let err = refine(&h_inf, &grid, &image, &RefineOptions::default()).unwrap_err();
    assert!(matches!(err, HomographyError::DegenerateSolution { .. }));
    let mut h_nan = h_true();
    h_nan[(0, 1)] = f64::NAN;
    let err = refine(&h_nan, &grid, &image, &RefineOptions::default()).unwrap_err();
    assert!(matches!(err, HomographyError::DegenerateSolution { .. }));

    // A start that sends a data point to infinity (w' = 0 at grid point (0.25, 0)).
    let h_bad = Matrix3::new(800.0, 0.0, 320.0, 0.0, 800.0, 240.0, -4.0, 0.0, 1.0);
    let err = refine(&h_bad, &grid, &image, &RefineOptions::default()).unwrap_err();
    assert!(matches!(err, HomographyError::DegenerateSolution { .. }));
}

#[test]
fn errors_have_readable_messages() {
    let msg = HomographyError::NonFinite {
        index: 4,
        set: PointSet::Image,
    }
    .to_string();
    assert!(msg.contains("image") && msg.contains('4'), "{msg}");
    let msg = HomographyError::LengthMismatch {
        object: 3,
        image: 5,
    }
    .to_string();
    assert!(msg.contains('3') && msg.contains('5'), "{msg}");
}

#[test]
fn refine_on_underdetermined_points_reports_a_singular_system() {
    // `refine` does not repeat the DLT rank test; with only three distinct points the
    // normal equations are singular and it keeps the starting homography.
    let distinct = [
        Point2::new(0.0, 0.0),
        Point2::new(0.2, 0.0),
        Point2::new(0.1, 0.3),
    ];
    let object: Vec<_> = (0..10).map(|i| distinct[i % 3]).collect();
    let mut image = map_points(&h_true(), &object);
    image[0].x += 1.0;
    let est = refine(&h_true(), &object, &image, &RefineOptions::default()).unwrap();
    assert_eq!(
        est.termination,
        homography::RefineTermination::SingularSystem
    );
    assert_eq!(est.iterations, 0);
    assert_eq!(est.h, h_true());
    assert_eq!(est.rms, est.dlt_rms);
}
