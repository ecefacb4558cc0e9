//! Eight-lane loads and stores between structure-of-arrays buffers and
//! `wide::f32x8` registers.
//!
//! A batch's last group of lanes may be partial, so the natural
//! `f32x8::from(&v[start..end])` takes a slice of run-time length, which
//! compiles to a call to `memcpy` (and spills the registers around it) at
//! every group — millions of calls per render. These take a fixed-size
//! path for full groups and the slice path only for the tail.

use wide::f32x8;

/// Lanes `start..start + 8` of `v`; past its end, zeros.
#[inline(always)]
pub fn load(v: &[f32], start: usize) -> f32x8 {
    match v.get(start..start + 8) {
        Some(full) => f32x8::from(<[f32; 8]>::try_from(full).unwrap()),
        None => f32x8::from(&v[start..]),
    }
}

/// Writes the lanes of `x` to `v[start..]`, as many as fit.
#[inline(always)]
pub fn store(v: &mut [f32], start: usize, x: f32x8) {
    match v.get_mut(start..start + 8) {
        Some(full) => {
            let full: &mut [f32; 8] = full.try_into().unwrap();
            *full = x.to_array();
        }
        None => {
            let tail = &mut v[start..];
            let n = tail.len();
            tail.copy_from_slice(&x.to_array()[..n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_and_partial_groups() {
        let v: Vec<f32> = (0..11).map(|i| i as f32).collect();
        assert_eq!(load(&v, 0).to_array(), [0., 1., 2., 3., 4., 5., 6., 7.]);
        assert_eq!(load(&v, 8).to_array(), [8., 9., 10., 0., 0., 0., 0., 0.]);
        let mut out = vec![-1.0; 11];
        store(&mut out, 0, load(&v, 0));
        store(&mut out, 8, load(&v, 8));
        assert_eq!(out, v);
    }
}
