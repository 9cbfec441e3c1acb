//! Every SE(2) Jacobian against central differences, on random poses and points.

use nalgebra::{DMatrix, DVector, Point2, Vector3};
use proptest::prelude::*;
use rperc_core::{Pose2, wrap_angle};

const H: f64 = 1e-6;

/// Central-difference Jacobian of `f` at `x`; angle outputs (listed in `angles`) are
/// differenced with wrapping so a jump across pi does not look like a huge slope.
fn numeric(
    f: &dyn Fn(&DVector<f64>) -> DVector<f64>,
    x: &DVector<f64>,
    angles: &[usize],
) -> DMatrix<f64> {
    let m = f(x).len();
    let mut j = DMatrix::zeros(m, x.len());
    for k in 0..x.len() {
        let (mut a, mut b) = (x.clone(), x.clone());
        a[k] += H;
        b[k] -= H;
        let mut d = f(&a) - f(&b);
        for &i in angles {
            d[i] = wrap_angle(d[i]);
        }
        j.set_column(k, &(d / (2.0 * H)));
    }
    j
}

fn pose(v: &[f64]) -> Pose2 {
    Pose2 {
        x: v[0],
        y: v[1],
        theta: v[2],
    }
}

fn vec_of(p: &Pose2) -> DVector<f64> {
    DVector::from_vec(vec![p.x, p.y, p.theta])
}

fn close(analytic: DMatrix<f64>, numeric: DMatrix<f64>) -> Result<(), TestCaseError> {
    let err = (&analytic - &numeric).amax();
    prop_assert!(
        err < 1e-6 * (1.0 + numeric.amax()),
        "analytic {analytic} numeric {numeric}"
    );
    Ok(())
}

fn coord() -> impl Strategy<Value = f64> {
    -20.0..20.0f64
}
fn heading() -> impl Strategy<Value = f64> {
    -3.1..3.1f64
}

proptest! {
    #[test]
    fn compose_jacobians(a in (coord(), coord(), heading()), b in (coord(), coord(), heading())) {
        let x = DVector::from_vec(vec![a.0, a.1, a.2, b.0, b.1, b.2]);
        let f = |v: &DVector<f64>| vec_of(&pose(&v.as_slice()[..3]).compose(&pose(&v.as_slice()[3..])));
        let j = numeric(&f, &x, &[2]);
        let (_, ja, jb) = pose(&x.as_slice()[..3]).compose_with_jacobians(&pose(&x.as_slice()[3..]));
        close(DMatrix::from_column_slice(3, 3, ja.as_slice()), j.columns(0, 3).into_owned())?;
        close(DMatrix::from_column_slice(3, 3, jb.as_slice()), j.columns(3, 3).into_owned())?;
    }

    #[test]
    fn inverse_and_between_jacobians(a in (coord(), coord(), heading()), b in (coord(), coord(), heading())) {
        let x = DVector::from_vec(vec![a.0, a.1, a.2]);
        let f = |v: &DVector<f64>| vec_of(&pose(v.as_slice()).inverse());
        let (_, ji) = pose(x.as_slice()).inverse_with_jacobian();
        close(DMatrix::from_column_slice(3, 3, ji.as_slice()), numeric(&f, &x, &[2]))?;

        let x = DVector::from_vec(vec![a.0, a.1, a.2, b.0, b.1, b.2]);
        let g = |v: &DVector<f64>| vec_of(&pose(&v.as_slice()[..3]).between(&pose(&v.as_slice()[3..])));
        let j = numeric(&g, &x, &[2]);
        let (_, ja, jb) = pose(&x.as_slice()[..3]).between_with_jacobians(&pose(&x.as_slice()[3..]));
        close(DMatrix::from_column_slice(3, 3, ja.as_slice()), j.columns(0, 3).into_owned())?;
        close(DMatrix::from_column_slice(3, 3, jb.as_slice()), j.columns(3, 3).into_owned())?;
    }

    #[test]
    fn point_jacobians(a in (coord(), coord(), heading()), p in (coord(), coord())) {
        let x = DVector::from_vec(vec![a.0, a.1, a.2, p.0, p.1]);
        for inverse in [false, true] {
            let f = |v: &DVector<f64>| {
                let (q, pt) = (pose(&v.as_slice()[..3]), Point2::new(v[3], v[4]));
                let r = if inverse { q.inverse_transform_point(&pt) } else { q.transform_point(&pt) };
                DVector::from_vec(vec![r.x, r.y])
            };
            let j = numeric(&f, &x, &[]);
            let (q, pt) = (pose(&x.as_slice()[..3]), Point2::new(x[3], x[4]));
            let (_, jp, jq) = if inverse {
                q.inverse_transform_point_with_jacobians(&pt)
            } else {
                q.transform_point_with_jacobians(&pt)
            };
            close(DMatrix::from_column_slice(2, 3, jp.as_slice()), j.columns(0, 3).into_owned())?;
            close(DMatrix::from_column_slice(2, 2, jq.as_slice()), j.columns(3, 2).into_owned())?;
        }
    }

    /// Group laws, independent of the Jacobians: a (+) a^-1 = identity, between = inverse-compose.
    #[test]
    fn group_laws(a in (coord(), coord(), heading()), b in (coord(), coord(), heading())) {
        let (a, b) = (Pose2::new(a.0, a.1, a.2), Pose2::new(b.0, b.1, b.2));
        let id = a.compose(&a.inverse());
        prop_assert!(id.to_vector().norm() < 1e-9);
        let d = a.between(&b);
        let back = a.compose(&d);
        prop_assert!((back.translation() - b.translation()).norm() < 1e-9);
        prop_assert!(wrap_angle(back.theta - b.theta).abs() < 1e-12);
        let v = Vector3::new(a.x, a.y, a.theta);
        prop_assert_eq!(Pose2::from_vector(&v), a);
    }
}
