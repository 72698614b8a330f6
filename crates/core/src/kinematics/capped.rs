//! [`Capped`]: a `Copy` vector of at most `CAP` items stored inline, the storage of everything
//! sized by the joint count (joint angles, parameters, limits), which is a property of the model
//! (4 to [`super::MAX_JOINTS`] joints) and not of the type. It dereferences to a slice of its
//! `len` items, so indexing, iteration and slice methods work as on an array.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::ops::{Deref, DerefMut};

/// At most `CAP` items inline; the slots past `len` hold `T::default()` and are never read.
#[derive(Clone, Copy)]
pub struct Capped<T: Copy + Default, const CAP: usize> {
    len: u8,
    items: [T; CAP],
}

impl<T: Copy + Default, const CAP: usize> Capped<T, CAP> {
    /// `len` copies of `value`.
    ///
    /// # Panics
    ///
    /// When `len > CAP` (a length the caller has not checked against the model's joint count).
    pub fn filled(len: usize, value: T) -> Self {
        assert!(len <= CAP, "{len} items do not fit in {CAP}");
        let mut items = [T::default(); CAP];
        items[..len].fill(value);
        Capped {
            len: len as u8,
            items,
        }
    }

    /// A copy of `items`, or `None` when there are more than `CAP`.
    pub fn try_from_slice(items: &[T]) -> Option<Self> {
        (items.len() <= CAP).then(|| {
            let mut c = Self::filled(items.len(), T::default());
            c.items[..items.len()].copy_from_slice(items);
            c
        })
    }

    /// A copy of `items`.
    ///
    /// # Panics
    ///
    /// When there are more than `CAP` items.
    pub fn from_slice(items: &[T]) -> Self {
        Self::try_from_slice(items)
            .unwrap_or_else(|| panic!("{} items do not fit in {CAP}", items.len()))
    }

    /// Item `i` is `f(i)`, for `len` items.
    pub fn from_fn(len: usize, mut f: impl FnMut(usize) -> T) -> Self {
        let mut c = Self::filled(len, T::default());
        for (i, v) in c.iter_mut().enumerate() {
            *v = f(i);
        }
        c
    }

    /// `f` of every item.
    pub fn map<U: Copy + Default>(&self, mut f: impl FnMut(T) -> U) -> Capped<U, CAP> {
        Capped::from_fn(self.len(), |i| f(self[i]))
    }
}

impl<T: Copy + Default, const CAP: usize> Default for Capped<T, CAP> {
    fn default() -> Self {
        Self::filled(0, T::default())
    }
}

impl<T: Copy + Default, const CAP: usize> Deref for Capped<T, CAP> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.items[..self.len as usize]
    }
}

impl<T: Copy + Default, const CAP: usize> DerefMut for Capped<T, CAP> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.items[..self.len as usize]
    }
}

impl<T: Copy + Default, const CAP: usize> AsRef<[T]> for Capped<T, CAP> {
    fn as_ref(&self) -> &[T] {
        self
    }
}

impl<T: Copy + Default + PartialEq, const CAP: usize> PartialEq for Capped<T, CAP> {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl<T: Copy + Default + std::fmt::Debug, const CAP: usize> std::fmt::Debug for Capped<T, CAP> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        (**self).fmt(f)
    }
}

impl<T: Copy + Default, const CAP: usize, const N: usize> From<[T; N]> for Capped<T, CAP> {
    fn from(a: [T; N]) -> Self {
        Self::from_slice(&a)
    }
}

impl<T: Copy + Default, const CAP: usize> From<&[T]> for Capped<T, CAP> {
    fn from(a: &[T]) -> Self {
        Self::from_slice(a)
    }
}

impl<T: Copy + Default, const CAP: usize> FromIterator<T> for Capped<T, CAP> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        let mut c = Self::default();
        for v in iter {
            assert!((c.len as usize) < CAP, "more than {CAP} items");
            c.items[c.len as usize] = v;
            c.len += 1;
        }
        c
    }
}

impl<'a, T: Copy + Default, const CAP: usize> IntoIterator for &'a Capped<T, CAP> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<T: Copy + Default, const CAP: usize> IntoIterator for Capped<T, CAP> {
    type Item = T;
    type IntoIter = std::iter::Take<std::array::IntoIter<T, CAP>>;
    fn into_iter(self) -> Self::IntoIter {
        self.items.into_iter().take(self.len as usize)
    }
}

impl<T: Copy + Default + Serialize, const CAP: usize> Serialize for Capped<T, CAP> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (**self).serialize(s)
    }
}

impl<'de, T: Copy + Default + Deserialize<'de>, const CAP: usize> Deserialize<'de>
    for Capped<T, CAP>
{
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<T>::deserialize(d)?;
        Self::try_from_slice(&v).ok_or_else(|| {
            serde::de::Error::custom(format!("at most {CAP} values, found {}", v.len()))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Capped;

    #[test]
    fn behaves_as_its_slice() {
        let mut a: Capped<f64, 7> = [1.0, 2.0, 3.0].into();
        assert_eq!(a.len(), 3);
        a[1] = 5.0;
        assert_eq!(&*a, &[1.0, 5.0, 3.0]);
        assert_eq!(a.map(|x| 2.0 * x), Capped::<f64, 7>::from([2.0, 10.0, 6.0]));
        assert_eq!(a.into_iter().sum::<f64>(), 9.0);
        assert_eq!(format!("{a:?}"), "[1.0, 5.0, 3.0]");
        assert!(Capped::<f64, 2>::try_from_slice(&[1.0; 3]).is_none());
        let j = serde_json::to_string(&a).unwrap();
        assert_eq!(j, "[1.0,5.0,3.0]");
        assert_eq!(serde_json::from_str::<Capped<f64, 7>>(&j).unwrap(), a);
        assert!(serde_json::from_str::<Capped<f64, 2>>(&j).is_err());
        // Slots past the length never take part in equality.
        let mut b = Capped::<f64, 7>::from([1.0, 5.0, 3.0, 9.0]);
        assert_ne!(a, b);
        b = Capped::from_slice(&b[..3]);
        assert_eq!(a, b);
    }
}
