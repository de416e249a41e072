//! A small LMI layer on Clarabel: scalar, symmetric and free matrix variables, affine matrix
//! expressions in them, `F(x) ⪯ −εI` / `F(x) ⪰ εI` constraints, a linear objective.
//!
//! The problem description (variables, affine blocks) is kept apart from how it is handed to
//! the solver (`Problem::solve`): each constraint `G(x) = G₀ + Σ xₖ Gₖ ⪰ 0` becomes a
//! positive-semidefinite triangle cone `s = svec(G(x))`, i.e. Clarabel's `A x + s = b` with
//! `b = svec(G₀)` and `A = −[svec(G₁) …]`. Clarabel's `svec` is the upper triangle, column by
//! column (`(i ≤ j)` at `j(j+1)/2 + i`), off-diagonals times √2.
//!
//! **The solver is not trusted**: a `Solved` or `AlmostSolved` answer is accepted only after
//! every constraint is evaluated at the returned point and its eigenvalues checked here.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use nalgebra::{DMatrix, SymmetricEigen};
use std::collections::BTreeMap;

/// A matrix variable: `rows × cols` scalars starting at `offset` in the decision vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Var {
    offset: usize,
    rows: usize,
    cols: usize,
    symmetric: bool,
}

impl Var {
    pub fn rows(&self) -> usize {
        self.rows
    }
    pub fn cols(&self) -> usize {
        self.cols
    }
    /// Scalar index of entry `(i, j)` (symmetric: stored once for `i ≤ j`).
    fn index(&self, i: usize, j: usize) -> usize {
        if self.symmetric {
            let (i, j) = if i <= j { (i, j) } else { (j, i) };
            self.offset + j * (j + 1) / 2 + i
        } else {
            self.offset + j * self.rows + i
        }
    }
    fn len(&self) -> usize {
        if self.symmetric {
            self.rows * (self.rows + 1) / 2
        } else {
            self.rows * self.cols
        }
    }
    /// The variable's value in a solution vector.
    pub fn value(&self, x: &[f64]) -> DMatrix<f64> {
        DMatrix::from_fn(self.rows, self.cols, |i, j| x[self.index(i, j)])
    }
    /// The variable as an affine expression.
    pub fn expr(&self) -> Affine {
        let mut a = Affine::zeros(self.rows, self.cols);
        for j in 0..self.cols {
            for i in 0..self.rows {
                let k = self.index(i, j);
                a.terms
                    .entry(k)
                    .or_insert_with(|| DMatrix::zeros(self.rows, self.cols))[(i, j)] = 1.0;
            }
        }
        a
    }
}

/// `F(x) = F₀ + Σₖ xₖ Fₖ`.
#[derive(Debug, Clone, PartialEq)]
pub struct Affine {
    pub constant: DMatrix<f64>,
    pub terms: BTreeMap<usize, DMatrix<f64>>,
}

impl Affine {
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Affine {
            constant: DMatrix::zeros(rows, cols),
            terms: BTreeMap::new(),
        }
    }
    pub fn constant(m: DMatrix<f64>) -> Self {
        Affine {
            constant: m,
            terms: BTreeMap::new(),
        }
    }
    pub fn identity(n: usize) -> Self {
        Self::constant(DMatrix::identity(n, n))
    }
    pub fn nrows(&self) -> usize {
        self.constant.nrows()
    }
    pub fn ncols(&self) -> usize {
        self.constant.ncols()
    }
    fn map(&self, f: impl Fn(&DMatrix<f64>) -> DMatrix<f64>) -> Affine {
        Affine {
            constant: f(&self.constant),
            terms: self.terms.iter().map(|(k, m)| (*k, f(m))).collect(),
        }
    }
    /// `M F(x)`.
    pub fn left(&self, m: &DMatrix<f64>) -> Affine {
        self.map(|f| m * f)
    }
    /// `F(x) M`.
    pub fn right(&self, m: &DMatrix<f64>) -> Affine {
        self.map(|f| f * m)
    }
    pub fn scale(&self, s: f64) -> Affine {
        self.map(|f| f * s)
    }
    pub fn t(&self) -> Affine {
        self.map(|f| f.transpose())
    }
    pub fn add(&self, other: &Affine) -> Affine {
        assert_eq!(
            self.constant.shape(),
            other.constant.shape(),
            "affine sum of different shapes"
        );
        let mut out = self.clone();
        out.constant += &other.constant;
        for (k, m) in &other.terms {
            *out.terms
                .entry(*k)
                .or_insert_with(|| DMatrix::zeros(m.nrows(), m.ncols())) += m;
        }
        out
    }
    pub fn sub(&self, other: &Affine) -> Affine {
        self.add(&other.scale(-1.0))
    }
    /// `F` placed at `(r, c)` of a `rows × cols` zero matrix.
    pub fn embed(&self, rows: usize, cols: usize, r: usize, c: usize) -> Affine {
        self.map(|f| {
            let mut m = DMatrix::zeros(rows, cols);
            m.view_mut((r, c), f.shape()).copy_from(f);
            m
        })
    }
    /// `He(F) = F + Fᵀ`.
    pub fn he(&self) -> Affine {
        self.add(&self.t())
    }
    /// Value at `x`.
    pub fn eval(&self, x: &[f64]) -> DMatrix<f64> {
        let mut v = self.constant.clone();
        for (k, m) in &self.terms {
            v += m * x[*k];
        }
        v
    }
    /// A symmetric block matrix from its upper-triangular blocks (`None` = zero); the lower
    /// blocks are the transposes.
    pub fn symmetric_blocks(upper: &[Vec<Option<Affine>>]) -> Affine {
        let n = upper.len();
        let size = |i: usize| {
            upper[i][i]
                .as_ref()
                .map(|b| b.nrows())
                .unwrap_or_else(|| panic!("diagonal block {i} must be given"))
        };
        let sizes: Vec<usize> = (0..n).map(size).collect();
        let offsets: Vec<usize> = sizes
            .iter()
            .scan(0, |acc, s| {
                let o = *acc;
                *acc += s;
                Some(o)
            })
            .collect();
        let total: usize = sizes.iter().sum();
        let mut out = Affine::zeros(total, total);
        let mut place = |blk: &Affine, r: usize, c: usize| {
            out.constant
                .view_mut((r, c), blk.constant.shape())
                .copy_from(&blk.constant);
            for (k, m) in &blk.terms {
                out.terms
                    .entry(*k)
                    .or_insert_with(|| DMatrix::zeros(total, total))
                    .view_mut((r, c), m.shape())
                    .copy_from(m);
            }
        };
        for i in 0..n {
            for j in i..n {
                if let Some(b) = &upper[i][j] {
                    assert_eq!(
                        b.constant.shape(),
                        (sizes[i], sizes[j]),
                        "block ({i}, {j}) has the wrong shape"
                    );
                    place(b, offsets[i], offsets[j]);
                    if i != j {
                        place(&b.t(), offsets[j], offsets[i]);
                    }
                }
            }
        }
        out
    }
}

/// `G(x) ⪰ margin·I` (`name` says which LMI, for messages).
#[derive(Debug, Clone)]
struct Constraint {
    name: String,
    g: Affine,
    margin: f64,
}

/// Why an LMI problem has no accepted solution.
#[derive(Debug, thiserror::Error)]
pub enum LmiError {
    #[error("the solver could not be set up: {0}")]
    Setup(String),
    #[error("the solver returned {status:?} (cost {cost:e})")]
    NotSolved { status: String, cost: f64 },
    #[error("the solver returned {status} but LMI '{name}' is violated at its point: extreme eigenvalue {eigenvalue:e}")]
    Violated {
        status: String,
        name: String,
        eigenvalue: f64,
    },
}

/// A solved problem: the decision vector, the objective, the worst constraint margin.
#[derive(Debug, Clone)]
pub struct Solution {
    pub x: Vec<f64>,
    pub objective: f64,
    pub status: String,
    /// Smallest eigenvalue of any `G(x) − margin·I` at the returned point (≥ 0 when accepted).
    pub worst_margin: f64,
    pub iterations: u32,
}

/// An LMI problem: minimise `cᵀx` subject to LMIs.
#[derive(Debug, Clone)]
pub struct Problem {
    n_vars: usize,
    constraints: Vec<Constraint>,
    objective: BTreeMap<usize, f64>,
    iterative_refinement: bool,
}

impl Default for Problem {
    fn default() -> Self {
        Problem {
            n_vars: 0,
            constraints: Vec::new(),
            objective: BTreeMap::new(),
            iterative_refinement: true,
        }
    }
}

impl Problem {
    pub fn new() -> Self {
        Self::default()
    }

    fn var(&mut self, rows: usize, cols: usize, symmetric: bool) -> Var {
        let v = Var {
            offset: self.n_vars,
            rows,
            cols,
            symmetric,
        };
        self.n_vars += v.len();
        v
    }
    pub fn symmetric(&mut self, n: usize) -> Var {
        self.var(n, n, true)
    }
    pub fn full(&mut self, rows: usize, cols: usize) -> Var {
        self.var(rows, cols, false)
    }
    pub fn scalar(&mut self) -> Var {
        self.var(1, 1, false)
    }
    pub fn n_vars(&self) -> usize {
        self.n_vars
    }

    /// `F(x) ⪯ −ε I`.
    pub fn negative_definite(&mut self, name: &str, f: Affine, eps: f64) {
        self.constraints.push(Constraint {
            name: name.into(),
            g: f.scale(-1.0),
            margin: eps,
        });
    }
    /// `F(x) ⪰ ε I`.
    pub fn positive_definite(&mut self, name: &str, f: Affine, eps: f64) {
        self.constraints.push(Constraint {
            name: name.into(),
            g: f,
            margin: eps,
        });
    }
    /// Minimise `Σ weight · (scalar variable)`.
    pub fn minimise(&mut self, v: &Var, weight: f64) {
        assert_eq!(
            (v.rows, v.cols),
            (1, 1),
            "objective terms are scalar variables"
        );
        *self.objective.entry(v.offset).or_insert(0.0) += weight;
    }

    /// Solve the KKT systems without Clarabel's iterative refinement: a third less time per
    /// iteration, for problems shown to solve accurately without it (our eigenvalue check of
    /// every constraint at the returned point still decides).
    pub fn without_iterative_refinement(&mut self) {
        self.iterative_refinement = false;
    }

    /// Solve with Clarabel and check every LMI at the returned point. Diagnostics on standard
    /// error: `LMI_TIMING` (size, assembly and solve time, iterations), `LMI_VERBOSE` (Clarabel's
    /// own log).
    pub fn solve(&self) -> Result<Solution, LmiError> {
        crate::single_threaded_blas();
        let t0 = std::time::Instant::now();
        let n = self.n_vars;
        let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
        let mut b = Vec::new();
        let mut cones = Vec::new();
        let sqrt2 = std::f64::consts::SQRT_2;
        let mut row0 = 0;
        for c in &self.constraints {
            let m = c.g.nrows();
            assert!(c.g.constant.is_square(), "LMI '{}' is not square", c.name);
            let svec_index = |i: usize, j: usize| row0 + j * (j + 1) / 2 + i;
            for j in 0..m {
                for i in 0..=j {
                    let s = if i == j { 1.0 } else { sqrt2 };
                    // Symmetrise: the LMI means (G + Gᵀ)/2.
                    let g0 = 0.5 * (c.g.constant[(i, j)] + c.g.constant[(j, i)])
                        - if i == j { c.margin } else { 0.0 };
                    b.push(s * g0);
                }
            }
            for (k, gk) in &c.g.terms {
                for j in 0..m {
                    for i in 0..=j {
                        let v = 0.5 * (gk[(i, j)] + gk[(j, i)]);
                        if v != 0.0 {
                            let s = if i == j { 1.0 } else { sqrt2 };
                            rows.push(svec_index(i, j));
                            cols.push(*k);
                            vals.push(-s * v);
                        }
                    }
                }
            }
            cones.push(SupportedConeT::PSDTriangleConeT(m));
            row0 += m * (m + 1) / 2;
        }
        let a = CscMatrix::new_from_triplets(row0, n, rows, cols, vals);
        let p = CscMatrix::zeros((n, n));
        let mut q = vec![0.0; n];
        for (k, w) in &self.objective {
            q[*k] = *w;
        }
        let settings = DefaultSettingsBuilder::default()
            .verbose(std::env::var_os("LMI_VERBOSE").is_some())
            .max_iter(500)
            // One thread: `synth` runs the designs in parallel, one per core, and faer's own
            // threads only contend with them (hinf_of alone: 1.2 s with one, 2.0 s with two).
            .max_threads(1)
            .iterative_refinement_enable(self.iterative_refinement)
            .build()
            .map_err(|e| LmiError::Setup(e.to_string()))?;
        let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings)
            .map_err(|e| LmiError::Setup(format!("{e:?}")))?;
        let t1 = std::time::Instant::now();
        solver.solve();
        if std::env::var_os("LMI_TIMING").is_some() {
            eprintln!(
                "lmi: {n} vars, {row0} cone rows: assembly {:?}, solve {:?} ({} iterations)",
                t1 - t0,
                t1.elapsed(),
                solver.info.iterations
            );
        }
        let status = format!("{:?}", solver.solution.status);
        if !matches!(
            solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        ) {
            return Err(LmiError::NotSolved {
                status,
                cost: solver.solution.obj_val,
            });
        }
        let x = solver.solution.x.clone();
        let mut worst = f64::INFINITY;
        for c in &self.constraints {
            let g = c.g.eval(&x);
            let sym = (&g + g.transpose()) * 0.5;
            let min_eig = SymmetricEigen::new(sym).eigenvalues.min();
            // Strict feasibility of the original LMI (G ≻ 0) is what the theorems need; the
            // solver's margin is only a means to get there.
            if min_eig.is_nan() || min_eig <= 0.0 {
                return Err(LmiError::Violated {
                    status,
                    name: c.name.clone(),
                    eigenvalue: min_eig,
                });
            }
            worst = worst.min(min_eig - c.margin);
        }
        let objective = self.objective.iter().map(|(k, w)| w * x[*k]).sum();
        Ok(Solution {
            x,
            objective,
            status,
            worst_margin: worst,
            iterations: solver.info.iterations,
        })
    }
}

impl Affine {
    /// `Σᵢ vᵢ Mᵢ` for scalar variables `vᵢ` (e.g. a diagonal multiplier `diag(vᵢ)`, or
    /// `Σ vᵢ mᵢmᵢᵀ`), all `Mᵢ = term(i)` of one shape.
    pub fn combination(vars: &[Var], term: impl Fn(usize) -> DMatrix<f64>) -> Affine {
        let mats: Vec<DMatrix<f64>> = (0..vars.len()).map(term).collect();
        let (r, c) = mats.first().map_or((0, 0), |m| m.shape());
        vars.iter()
            .zip(&mats)
            .fold(Affine::zeros(r, c), |acc, (v, m)| {
                acc.add(&v.expr().map_scalar(m))
            })
    }

    /// The trace, a 1×1 expression.
    pub fn trace(&self) -> Affine {
        self.map(|f| DMatrix::from_element(1, 1, f.trace()))
    }

    /// For a 1×1 expression `s(x)`, the matrix expression `s(x)·M`.
    pub fn map_scalar(&self, m: &DMatrix<f64>) -> Affine {
        assert_eq!(
            self.constant.shape(),
            (1, 1),
            "map_scalar needs a scalar expression"
        );
        Affine {
            constant: m * self.constant[(0, 0)],
            terms: self
                .terms
                .iter()
                .map(|(k, v)| (*k, m * v[(0, 0)]))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svec_layout_matches_clarabel_convention() {
        // max t s.t. [[1, t], [t, 1]] ⪰ 0  →  t = 1; exercises the √2 off-diagonal scaling.
        let mut p = Problem::new();
        let t = p.scalar();
        let off = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 1.0, 0.0]);
        let f = Affine::identity(2).add(
            &t.expr()
                .left(&DMatrix::from_element(1, 1, 1.0))
                .map_scalar(&off),
        );
        p.positive_definite("unit", f, 0.0);
        p.minimise(&t, -1.0);
        // The optimum sits on the boundary: the solver's point is (just) inside or outside.
        match p.solve() {
            Ok(s) => assert!((s.objective + 1.0).abs() < 1e-6, "{}", s.objective),
            Err(LmiError::Violated { eigenvalue, .. }) => assert!(eigenvalue.abs() < 1e-7),
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn lyapunov_lmi_finds_a_certificate_and_infeasibility_is_reported() {
        // Stable A: P ≻ I, AᵀP + PA ≺ 0 is feasible; check it with the eigenvalues ourselves.
        let a = DMatrix::from_row_slice(3, 3, &[-1.0, 2.0, 0.0, -3.0, -1.0, 1.0, 0.0, 0.0, -0.5]);
        let mut p = Problem::new();
        let pv = p.symmetric(3);
        p.positive_definite("P ≻ I", pv.expr().sub(&Affine::identity(3)), 0.0);
        p.negative_definite("AᵀP + PA ≺ 0", pv.expr().left(&a.transpose()).he(), 1e-6);
        let s = p.solve().expect("feasible");
        let pm = pv.value(&s.x);
        let l = a.transpose() * &pm + &pm * &a;
        assert!(SymmetricEigen::new(l).eigenvalues.max() < 0.0);
        // An unstable A has no such P.
        let a_bad = DMatrix::from_row_slice(2, 2, &[0.1, 1.0, 0.0, -1.0]);
        let mut p = Problem::new();
        let pv = p.symmetric(2);
        p.positive_definite("P ≻ I", pv.expr().sub(&Affine::identity(2)), 0.0);
        p.negative_definite(
            "AᵀP + PA ≺ 0",
            pv.expr().left(&a_bad.transpose()).he(),
            1e-6,
        );
        assert!(p.solve().is_err());
    }

    #[test]
    fn combination_and_trace_evaluate_like_their_matrices() {
        let mut p = Problem::new();
        let vars: Vec<Var> = (0..3).map(|_| p.scalar()).collect();
        let m = |i: usize| DMatrix::from_fn(2, 2, |a, b| (i + 1) as f64 * (a + 2 * b) as f64);
        let x = [0.5, -2.0, 3.0];
        let comb = Affine::combination(&vars, m);
        let expected = m(0) * 0.5 + m(1) * -2.0 + m(2) * 3.0;
        assert_eq!(comb.eval(&x), expected);
        let sym = p.symmetric(3);
        let values: Vec<f64> = (0..p.n_vars()).map(|k| k as f64 + 1.0).collect();
        assert_eq!(
            sym.expr().trace().eval(&values)[(0, 0)],
            sym.value(&values).trace()
        );
    }
}
