//! Measurement streams: a readable identity per stream and the per-stream state of
//! strategies.

/// Identifies a measurement stream (GNSS position, GNSS velocity, magnetometer …) by a
/// readable name. Two ids are the same stream when their names are equal (compared by a
/// precomputed hash, so the test is one integer comparison).
///
/// ```
/// use estimator_core::StreamId;
///
/// const COMPASS: StreamId = StreamId::named("compass");
/// assert_eq!(COMPASS.name(), "compass");
/// assert_eq!(COMPASS, StreamId::named("compass"));
/// assert_ne!(COMPASS, StreamId::named("gnss-position"));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct StreamId {
    hash: u64,
    name: &'static str,
}

impl PartialEq for StreamId {
    fn eq(&self, other: &Self) -> bool {
        self.hash == other.hash && self.name == other.name
    }
}

impl Eq for StreamId {}

impl core::hash::Hash for StreamId {
    fn hash<H: core::hash::Hasher>(&self, state: &mut H) {
        self.hash.hash(state)
    }
}

impl core::fmt::Display for StreamId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name)
    }
}

const fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut i = 0;
    while i < bytes.len() {
        h ^= bytes[i] as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
        i += 1;
    }
    h
}

impl StreamId {
    /// A stream named `name` (usable in `const`).
    pub const fn named(name: &'static str) -> Self {
        Self { hash: fnv1a(name.as_bytes()), name }
    }

    /// The default stream of a model type: named by the type's path without its module
    /// (`LinearMeasurement<2, 4>`, `GnssPosition`).
    pub fn of<T: ?Sized>() -> Self {
        Self::named(short_type_name::<T>())
    }

    /// The stream's name, for reports and logs.
    pub const fn name(&self) -> &'static str {
        self.name
    }
}

/// `core::any::type_name` without the module paths (`a::b::C<d::E>` → `C<E>`).
pub fn short_type_name<T: ?Sized>() -> &'static str {
    let full = core::any::type_name::<T>();
    // Only paths without generic arguments can be shortened to a suffix of the full name;
    // with them, the module prefix of the outer type is dropped.
    match full.find('<') {
        None => full.rsplit("::").next().unwrap_or(full),
        Some(open) => {
            let head = &full[..open];
            match head.rfind("::") {
                Some(i) => &full[i + 2..],
                None => full,
            }
        }
    }
}

/// Per-stream state of a strategy: a small vector searched linearly (a filter has a
/// handful of streams). Allocates only when a new stream first appears (feature `std`).
#[cfg(feature = "std")]
#[derive(Debug, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StreamMap<T> {
    entries: Vec<(StreamId, T)>,
}

/// `clone_from` refills the entries in place (the filter copies its strategy before every
/// update; a derived `Clone` would allocate a new vector each time).
#[cfg(feature = "std")]
impl<T: Clone> Clone for StreamMap<T> {
    fn clone(&self) -> Self {
        Self { entries: self.entries.clone() }
    }

    fn clone_from(&mut self, source: &Self) {
        clone_entries_from(&mut self.entries, &source.entries);
    }
}

/// `dst ← src` for `(id, value)` entries, each value refilled in place with its own
/// `clone_from` (a tuple's `clone_from` makes a new copy of its parts), the vector's
/// room kept.
#[cfg(feature = "std")]
pub fn clone_entries_from<K: Copy, T: Clone>(dst: &mut Vec<(K, T)>, src: &[(K, T)]) {
    dst.truncate(src.len());
    for ((k, v), (sk, sv)) in dst.iter_mut().zip(src) {
        *k = *sk;
        v.clone_from(sv);
    }
    let have = dst.len();
    dst.extend_from_slice(&src[have..]);
}

#[cfg(feature = "std")]
impl<T> StreamMap<T> {
    /// An empty map.
    pub fn new() -> Self {
        Self { entries: Vec::new() }
    }

    /// The entry of `id`, created with `make` on first use.
    pub fn get_or_insert_with(&mut self, id: StreamId, make: impl FnOnce() -> T) -> &mut T {
        let i = match self.entries.iter().position(|(k, _)| *k == id) {
            Some(i) => i,
            None => {
                self.entries.push((id, make()));
                self.entries.len() - 1
            }
        };
        &mut self.entries[i].1
    }

    /// The entry of `id`, if any.
    pub fn get(&self, id: StreamId) -> Option<&T> {
        self.entries.iter().find(|(k, _)| *k == id).map(|(_, v)| v)
    }

    /// Every stream seen with its entry, in the order first seen.
    pub fn iter(&self) -> impl Iterator<Item = (StreamId, &T)> {
        self.entries.iter().map(|(k, v)| (*k, v))
    }

    /// Number of streams seen.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True before any stream was seen.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// A stream (de)serialises as its name and hash; a deserialised name is leaked to give it
/// the `'static` lifetime (one small string per stream and checkpoint read).
#[cfg(feature = "serde")]
impl serde::Serialize for StreamId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        serde::Serialize::serialize(&(self.name, self.hash), s)
    }
}

#[cfg(feature = "serde")]
impl<'de> serde::Deserialize<'de> for StreamId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (name, hash): (String, u64) = serde::Deserialize::deserialize(d)?;
        let id = StreamId::named(Box::leak(name.into_boxed_str()));
        if id.hash != hash {
            return Err(serde::de::Error::custom("stream name and hash disagree"));
        }
        Ok(id)
    }
}
