//! The value checks shared by configurations and scenario files: each names the key.

/// Every value finite.
pub(crate) fn finite(key: &str, v: &[f64]) -> Result<(), String> {
    match v.iter().find(|x| !x.is_finite()) {
        Some(x) => Err(format!("`{key}` must be finite, got {x}")),
        None => Ok(()),
    }
}

/// Every value finite and positive.
pub(crate) fn positive(key: &str, v: &[f64]) -> Result<(), String> {
    finite(key, v)?;
    match v.iter().find(|x| **x <= 0.0) {
        Some(x) => Err(format!("`{key}` must be positive, got {x}")),
        None => Ok(()),
    }
}

/// Every value finite and not negative.
pub(crate) fn nonneg(key: &str, v: &[f64]) -> Result<(), String> {
    finite(key, v)?;
    match v.iter().find(|x| **x < 0.0) {
        Some(x) => Err(format!("`{key}` must not be negative, got {x}")),
        None => Ok(()),
    }
}
