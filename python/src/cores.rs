//! What every filter core behind the Python callables offers, compiled (`callables`, states
//! up to [`MAX_N`], updates up to [`MAX_M`]) or on the heap (`dynamic`, beyond them): the
//! [`Core`] operations, an update's results ([`Updated`]), and a core as bytes for pickle.

/// Largest state dimension of a core.
pub const MAX_N: usize = 9;
/// Largest measurement dimension of an update.
pub const MAX_M: usize = 8;

/// What an update gives back, row-major.
#[derive(Default)]
pub(crate) struct Updated {
    pub(crate) x: Vec<f64>,
    pub(crate) P: Vec<f64>,
    pub(crate) K: Vec<f64>,
    pub(crate) S: Vec<f64>,
    pub(crate) nis: f64,
    pub(crate) nis_adapted: f64,
    pub(crate) log_likelihood: f64,
    pub(crate) verdict: &'static str,
}

/// A core as bytes (postcard: every float bit for bit, NaN included), for pickle.
pub(crate) fn to_bytes<T: serde::Serialize>(core: &T) -> Result<Vec<u8>, String> {
    postcard::to_allocvec(core).map_err(|e| e.to_string())
}

/// A core from [`to_bytes`]'s bytes.
pub(crate) fn from_bytes<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    postcard::from_bytes(bytes).map_err(|e| e.to_string())
}

/// The operations of a core, whatever its dimension.
pub(crate) trait Core: Send + Sync {
    fn set(&mut self, x: &[f64], P: &[f64]) -> Result<(), String>;
    fn predict(&mut self, x: &[f64], F: &[f64], Q: &[f64], dt: f64) -> Result<Vec<f64>, String>;
    /// `stats`: `H` holds `P_xz` (`n × m`) and `Pzz` the points' spread of `h`.
    fn update(
        &mut self,
        y: &[f64],
        H: &[f64],
        R: &[f64],
        Pzz: Option<&[f64]>,
    ) -> Result<Updated, String>;
    fn smooth(&self) -> Result<(Vec<f64>, Vec<f64>), String>;
    fn strategy(&self) -> &'static str;
    /// The whole core (state, covariance, strategy state, smoothing history) as bytes
    /// (postcard: every float bit for bit, NaN included).
    fn save(&self) -> Result<Vec<u8>, String>;
    /// The core [`save`](Core::save) wrote.
    fn restore(&mut self, state: &[u8]) -> Result<(), String>;
    /// Forget the recorded predictions: the next one starts a new smoothing history.
    fn reset_history(&mut self);
}
