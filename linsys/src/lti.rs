//! The state-space system.

use nalgebra::DMatrix;

/// `ẋ = A x + B u`, `y = C x + D u`.
#[derive(Debug, Clone, PartialEq)]
pub struct Lti {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
}

impl Lti {
    /// Panics on inconsistent dimensions (a programming error: data from a file is checked by
    /// its reader first).
    pub fn new(a: DMatrix<f64>, b: DMatrix<f64>, c: DMatrix<f64>, d: DMatrix<f64>) -> Self {
        let n = a.nrows();
        assert!(
            a.is_square()
                && b.nrows() == n
                && c.ncols() == n
                && d.shape() == (c.nrows(), b.ncols()),
            "inconsistent LTI dimensions"
        );
        Lti { a, b, c, d }
    }

    /// `y = D u`: no states.
    pub fn static_gain(d: DMatrix<f64>) -> Self {
        let (m, p) = d.shape();
        Lti {
            a: DMatrix::zeros(0, 0),
            b: DMatrix::zeros(0, p),
            c: DMatrix::zeros(m, 0),
            d,
        }
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        self.a.nrows()
    }

    /// The system from all inputs to the outputs `rows`.
    pub fn select_outputs(&self, rows: &[usize]) -> Lti {
        Lti::new(
            self.a.clone(),
            self.b.clone(),
            self.c.select_rows(rows),
            self.d.select_rows(rows),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_static_gain_has_no_states_and_outputs_select_rows() {
        let k = Lti::static_gain(DMatrix::from_row_slice(
            2,
            3,
            &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        ));
        assert_eq!((k.order(), k.b.shape(), k.c.shape()), (0, (0, 3), (2, 0)));
        let second = k.select_outputs(&[1]);
        assert_eq!(second.d, DMatrix::from_row_slice(1, 3, &[4.0, 5.0, 6.0]));
    }

    #[test]
    #[should_panic(expected = "inconsistent LTI dimensions")]
    fn inconsistent_dimensions_are_refused() {
        Lti::new(
            DMatrix::zeros(2, 2),
            DMatrix::zeros(3, 1),
            DMatrix::zeros(1, 2),
            DMatrix::zeros(1, 1),
        );
    }
}
