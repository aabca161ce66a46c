//! The composition tables: consistency and the order conditions they must satisfy.
//!
//! For a symmetric composition of a symmetric order-2 method the conditions include
//! `Σγ = 1` and `Σγ^{2j+1} = 0` for `2j + 1 < p` (GNI §V.3.2 / McLachlan 1995): the latter are the
//! coefficients of the `h^{2j+1}` terms that multiply the leading error of the base method.

use lieflow::flow::coefficients::{ALL_TABLES, table_by_name};

#[test]
fn tables_are_symmetric_and_consistent() {
    for t in ALL_TABLES {
        assert_eq!(t.half.len(), t.stages.div_ceil(2), "{}", t.name);
        assert_eq!(t.half_lo.len(), t.half.len(), "{}", t.name);
        for i in 0..t.stages {
            assert_eq!(
                t.gamma(i),
                t.gamma(t.stages - 1 - i),
                "{} stage {i}",
                t.name
            );
        }
        assert!(
            t.has_negative_steps(),
            "{}: every table above order 2 steps backwards",
            t.name
        );
        assert_eq!(table_by_name(t.name).unwrap().name, t.name);
        for lo in t.half_lo {
            assert!(lo.abs() < 1e-15, "{}: low part {lo:e} too large", t.name);
        }
    }
}

#[test]
fn order_conditions_hold_in_f64() {
    for t in ALL_TABLES {
        let sum: f64 = t.gammas().sum();
        assert!((sum - 1.0).abs() < 1e-14, "{}: sum {sum}", t.name);
        for power in (3..t.order as i32).step_by(2) {
            let s: f64 = t.gammas().map(|g| g.powi(power)).sum();
            assert!(s.abs() < 1e-13, "{}: sum of gamma^{power} = {s:e}", t.name);
        }
    }
}

#[test]
fn order_conditions_hold_in_double_double() {
    use twofloat::TwoFloat;
    for t in ALL_TABLES {
        let g: Vec<TwoFloat> = (0..t.stages).map(|i| t.gamma_in::<TwoFloat>(i)).collect();
        let sum = g.iter().fold(TwoFloat::from(0.0), |a, &b| a + b) - TwoFloat::from(1.0);
        assert!(
            f64::from(sum).abs() < 1e-25,
            "{}: sum - 1 = {:e}",
            t.name,
            f64::from(sum)
        );
        for power in (3..t.order as i32).step_by(2) {
            let s = g
                .iter()
                .fold(TwoFloat::from(0.0), |a, &b| a + b.powi(power));
            assert!(
                f64::from(s).abs() < 1e-24,
                "{}: gamma^{power} sum {:e}",
                t.name,
                f64::from(s)
            );
        }
    }
}
