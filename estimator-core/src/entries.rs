//! Column access to covariance storage, shared by the back-ends, the strategies' view of
//! `P⁻` and the block reset.

/// Column access to a square column-major matrix, so the block reset
/// (`block_reset_in_place`) is written once for every back-end.
pub trait Entries<T: Copy = f64> {
    /// Column `c`, contiguous.
    fn col(&self, c: usize) -> &[T];
    /// Column `c`, contiguous and mutable.
    fn col_mut(&mut self, c: usize) -> &mut [T];
    /// Entry `(r, c)`.
    #[inline(always)]
    fn at(&self, r: usize, c: usize) -> T {
        self.col(c)[r]
    }
    /// Set entry `(r, c)`.
    #[inline(always)]
    fn put(&mut self, r: usize, c: usize, v: T) {
        self.col_mut(c)[r] = v;
    }
}

impl<T: nalgebra::Scalar + Copy, R: nalgebra::Dim, C: nalgebra::Dim, S> Entries<T>
    for nalgebra::Matrix<T, R, C, S>
where
    S: nalgebra::RawStorageMut<T, R, C> + nalgebra::IsContiguous,
{
    #[inline(always)]
    fn col(&self, c: usize) -> &[T] {
        let n = self.nrows();
        &self.as_slice()[c * n..(c + 1) * n]
    }
    #[inline(always)]
    fn col_mut(&mut self, c: usize) -> &mut [T] {
        let n = self.nrows();
        &mut self.as_mut_slice()[c * n..(c + 1) * n]
    }
}
