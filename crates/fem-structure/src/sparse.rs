//! Symmetric sparse matrices (both triangles stored, compressed columns, faer's
//! `SparseColMat`) and their Cholesky factorisation `P A P^T = L L^T` (faer's sparse
//! supernodal/simplicial Cholesky with an AMD fill-reducing ordering); complex combinations
//! `sum_k c_k A_k` (the dynamic stiffness `K + s B + s^2 M` at a complex shift `s`, complex
//! symmetric, not Hermitian) by faer's sparse LU with partial pivoting ([`ComplexFactor`]).

use faer::Side;
use faer::c64;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, Lu};
use faer::sparse::{SparseColMat, Triplet};

use crate::error::StructureError;
use crate::mtx::{SymTriplets, sum_duplicates};

/// A symmetric sparse matrix, both triangles stored.
#[derive(Clone, Debug)]
pub struct SparseSym {
    mat: SparseColMat<usize, f64>,
}

/// A Cholesky factorisation of a [`SparseSym`], solving in place.
#[derive(Clone, Debug)]
pub struct SparseFactor {
    llt: Llt<usize, f64>,
    n: usize,
}

/// An LU factorisation of a complex combination of [`SparseSym`]s
/// ([`ComplexFactor::combination`]), solving in place.
#[derive(Clone, Debug)]
pub struct ComplexFactor {
    lu: Lu<usize, c64>,
    n: usize,
}

impl SparseSym {
    /// From the lower triangle of a symmetric matrix (`column <= row`, no duplicates).
    pub fn from_lower(t: &SymTriplets) -> Result<SparseSym, StructureError> {
        let mut entries = Vec::with_capacity(2 * t.lower.len());
        for &(i, j, v) in &t.lower {
            entries.push(Triplet::new(i, j, v));
            if i != j {
                entries.push(Triplet::new(j, i, v));
            }
        }
        let mat = SparseColMat::try_new_from_triplets(t.n, t.n, &entries)
            .map_err(|e| StructureError::Sparse(format!("{e:?}")))?;
        Ok(SparseSym { mat })
    }

    /// The lower triangle, sorted by `(column, row)`.
    pub fn lower(&self) -> SymTriplets {
        let r = self.mat.as_ref();
        let mut lower = Vec::new();
        for j in 0..self.n() {
            for (i, v) in r.row_idx_of_col(j).zip(r.val_of_col(j)) {
                if i >= j {
                    lower.push((i, j, *v));
                }
            }
        }
        SymTriplets { n: self.n(), lower }
    }

    /// Number of rows.
    pub fn n(&self) -> usize {
        self.mat.nrows()
    }

    /// Stored entries (both triangles).
    pub fn nnz(&self) -> usize {
        self.mat.as_ref().val().len()
    }

    /// `y += s A x`.
    pub fn mul_add_into(&self, s: f64, x: &[f64], y: &mut [f64]) {
        let r = self.mat.as_ref();
        for j in 0..self.n() {
            let xj = s * x[j];
            if xj == 0.0 {
                continue;
            }
            for (i, v) in r.row_idx_of_col(j).zip(r.val_of_col(j)) {
                y[i] += v * xj;
            }
        }
    }

    /// `Y += A X` for a block of `cols` vectors stored by rows (`X[i * cols + c]`, row-major
    /// `n x cols`): one pass over the non-zeros for the whole block, the inner loop over
    /// the block's contiguous row.
    pub fn mul_rows_add_into(&self, x: &[f64], y: &mut [f64], cols: usize) {
        let n = self.n();
        assert!(
            x.len() == n * cols && y.len() == n * cols,
            "SparseSym::mul_rows_add_into: wrong block size"
        );
        if cols == 0 {
            return;
        }
        let r = self.mat.as_ref();
        for (j, xj) in x.chunks_exact(cols).enumerate() {
            for (i, v) in r.row_idx_of_col(j).zip(r.val_of_col(j)) {
                for (yc, xc) in y[i * cols..(i + 1) * cols].iter_mut().zip(xj) {
                    *yc += v * xc;
                }
            }
        }
    }

    /// `x^T A x`.
    pub fn quadratic_form(&self, x: &[f64]) -> f64 {
        let r = self.mat.as_ref();
        let mut s = 0.0;
        for j in 0..self.n() {
            let mut c = 0.0;
            for (i, v) in r.row_idx_of_col(j).zip(r.val_of_col(j)) {
                c += v * x[i];
            }
            s += x[j] * c;
        }
        s
    }

    /// `|x|^T |A| |x|` (entries and components by their absolute values): the first-order
    /// change of `x^T A x` when every stored entry of `A` changes by at most one part in
    /// `1 / eps`, over `eps`.
    pub fn abs_quadratic_form(&self, x: &[f64]) -> f64 {
        let r = self.mat.as_ref();
        let mut s = 0.0;
        for j in 0..self.n() {
            let mut c = 0.0;
            for (i, v) in r.row_idx_of_col(j).zip(r.val_of_col(j)) {
                c += v.abs() * x[i].abs();
            }
            s += x[j].abs() * c;
        }
        s
    }

    /// Entry `(i, j)` (0 when not stored).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let r = self.mat.as_ref();
        r.row_idx_of_col(j)
            .zip(r.val_of_col(j))
            .find(|&(k, _)| k == i)
            .map_or(0.0, |(_, v)| *v)
    }

    /// `a A + b B` on the union of the two patterns.
    pub fn combination(&self, a: f64, other: &SparseSym, b: f64) -> SparseSym {
        let mut raw: Vec<(usize, usize, f64, ())> = self
            .lower()
            .lower
            .into_iter()
            .map(|(i, j, v)| (i, j, a * v, ()))
            .collect();
        raw.extend(
            other
                .lower()
                .lower
                .into_iter()
                .map(|(i, j, v)| (i, j, b * v, ())),
        );
        let lower = sum_duplicates(raw)
            .into_iter()
            .map(|(i, j, v, ())| (i, j, v))
            .collect();
        SparseSym::from_lower(&SymTriplets { n: self.n(), lower })
            .expect("indices of two matrices of the same size")
    }

    /// The principal submatrix on `keep` (sorted indices).
    pub fn principal(&self, keep: &[usize]) -> SparseSym {
        let mut map = vec![usize::MAX; self.n()];
        for (k, &i) in keep.iter().enumerate() {
            map[i] = k;
        }
        let lower = self
            .lower()
            .lower
            .into_iter()
            .filter(|&(i, j, _)| map[i] != usize::MAX && map[j] != usize::MAX)
            .map(|(i, j, v)| (map[i], map[j], v))
            .collect::<Vec<_>>();
        let mut lower = lower;
        lower.sort_by_key(|&(i, j, _)| (j, i));
        SparseSym::from_lower(&SymTriplets {
            n: keep.len(),
            lower,
        })
        .expect("indices of a submatrix")
    }

    /// Column `j` as `(row, value)` pairs.
    pub fn column(&self, j: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = self.mat.as_ref();
        r.row_idx_of_col(j).zip(r.val_of_col(j).iter().copied())
    }

    /// Cholesky factorisation; [`StructureError::NotPositiveDefinite`] names the matrix
    /// (`what`) when a pivot is not positive.
    pub fn factorize(&self, what: &str) -> Result<SparseFactor, StructureError> {
        let llt = self.mat.sp_cholesky(Side::Lower).map_err(|e| match e {
            faer::sparse::linalg::LltError::Numeric(_) => StructureError::NotPositiveDefinite {
                what: what.to_string(),
            },
            faer::sparse::linalg::LltError::Generic(g) => {
                StructureError::Sparse(format!("{what}: {g:?}"))
            }
        })?;
        Ok(SparseFactor { llt, n: self.n() })
    }
}

impl ComplexFactor {
    /// Factorises `sum_k c_k A_k` (the matrices of one size) on the union of their
    /// patterns. [`StructureError::Singular`] when the combination is singular: a pattern
    /// without a pivot, or a solve that is not finite.
    pub fn combination(terms: &[(c64, &SparseSym)]) -> Result<ComplexFactor, StructureError> {
        let n = terms.first().map_or(0, |t| t.1.n());
        let mut raw: Vec<(usize, usize, c64)> = Vec::new();
        for &(c, a) in terms {
            assert_eq!(a.n(), n, "ComplexFactor::combination: sizes differ");
            let r = a.mat.as_ref();
            for j in 0..n {
                for (i, v) in r.row_idx_of_col(j).zip(r.val_of_col(j)) {
                    raw.push((i, j, c * *v));
                }
            }
        }
        raw.sort_by_key(|&(i, j, _)| (j, i));
        let mut entries: Vec<Triplet<usize, usize, c64>> = Vec::with_capacity(raw.len());
        for (i, j, v) in raw {
            match entries.last_mut() {
                Some(t) if t.row == i && t.col == j => t.val += v,
                _ => entries.push(Triplet::new(i, j, v)),
            }
        }
        let mat = SparseColMat::try_new_from_triplets(n, n, &entries)
            .map_err(|e| StructureError::Sparse(format!("{e:?}")))?;
        let lu = mat.sp_lu().map_err(|e| match e {
            faer::sparse::linalg::LuError::SymbolicSingular { .. } => StructureError::Singular,
            faer::sparse::linalg::LuError::Generic(g) => StructureError::Sparse(format!("{g:?}")),
        })?;
        let f = ComplexFactor { lu, n };
        // A zero pivot shows as a non-finite solve.
        let mut probe = vec![c64::new(1.0, 0.0); n];
        f.solve_in_place(&mut probe);
        if probe
            .iter()
            .any(|v| !(v.re.is_finite() && v.im.is_finite()))
        {
            return Err(StructureError::Singular);
        }
        Ok(f)
    }

    /// `x <- A^-1 x`.
    pub fn solve_in_place(&self, x: &mut [c64]) {
        assert_eq!(
            x.len(),
            self.n,
            "ComplexFactor::solve_in_place: wrong length"
        );
        if self.n == 0 {
            return;
        }
        let m = faer::MatMut::from_column_major_slice_mut(x, self.n, 1);
        self.lu.solve_in_place(m);
    }
}

impl SparseFactor {
    /// `x <- A^-1 x`.
    pub fn solve_in_place(&self, x: &mut [f64]) {
        assert_eq!(
            x.len(),
            self.n,
            "SparseFactor::solve_in_place: wrong length"
        );
        let m = faer::MatMut::from_column_major_slice_mut(x, self.n, 1);
        self.llt.solve_in_place(m);
    }

    /// Solves for every column of `x` (column-major, `n` rows) at once.
    pub fn solve_columns_in_place(&self, x: &mut [f64]) {
        if self.n == 0 || x.is_empty() {
            return;
        }
        let cols = x.len() / self.n;
        let m = faer::MatMut::from_column_major_slice_mut(x, self.n, cols);
        self.llt.solve_in_place(m);
    }

    /// Number of rows.
    pub fn n(&self) -> usize {
        self.n
    }
}
