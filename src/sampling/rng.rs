//! Counter-based sample streams.
//!
//! A [`SampleStream`] is a (seed, pixel, sample) triple plus dimension
//! counters. Two-dimensional draws — the position within the pixel, each
//! light sample, each BSDF direction — come from a *padded* Owen-scrambled
//! Sobol (0,2)-sequence (Burley, "Practical Hash-based Owen Scrambling",
//! 2020): every pair of dimensions uses the same 2D sequence with its own
//! index shuffle and scrambles. Each pair on its own stratifies every
//! power-of-two prefix of a pixel's samples — so light and BSDF samples are
//! well spread whether a pixel ends after 4 samples or 2048 (adaptive
//! sampling) — while the shuffles decorrelate the pairs from each other.
//! Owen scrambling keeps every draw uniformly distributed, so estimators
//! stay unbiased. One-dimensional draws (roulette, picking a triangle) are
//! independent hashes of a counter.

use wide::{f32x8, f32x16, i32x8, i32x16, u32x8, u32x16};

use crate::lanes;

/// The integer operations the sampler's hashes are made of, for one stream
/// (`u32`) or eight or sixteen at once (`u32x8`, `u32x16`). Every hash
/// below is written once, generically, so the batched draws
/// ([`VertexDraws`]) are bit for bit the scalar ones. Bit operations are
/// the types' own operators; arithmetic wraps (the vectors' always does,
/// `u32`'s by its `wrapping_*` methods).
trait Word:
    Copy
    + std::ops::BitXor<Output = Self>
    + std::ops::BitAnd<Output = Self>
    + std::ops::Shr<u32, Output = Self>
    + std::ops::Shl<u32, Output = Self>
{
    fn splat(c: u32) -> Self;
    fn add(self, rhs: Self) -> Self;
    fn mul(self, rhs: Self) -> Self;
    fn reverse_bits(self) -> Self;
    /// `self ^= self * c`, the step of the Laine–Karras permutation.
    #[inline(always)]
    fn xor_mul(self, c: u32) -> Self {
        self ^ self.mul(Self::splat(c))
    }
}

impl Word for u32 {
    #[inline(always)]
    fn splat(c: u32) -> Self {
        c
    }
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        self.wrapping_add(rhs)
    }
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        self.wrapping_mul(rhs)
    }
    #[inline(always)]
    fn reverse_bits(self) -> Self {
        u32::reverse_bits(self)
    }
}

/// [`Word`] for a vector of `u32` lanes: eight streams at once, or
/// sixteen (one AVX-512 register) in the wave's draws.
macro_rules! word_lanes {
    ($t:ty) => {
        impl Word for $t {
            #[inline(always)]
            fn splat(c: u32) -> Self {
                <$t>::splat(c)
            }
            #[inline(always)]
            fn add(self, rhs: Self) -> Self {
                self + rhs
            }
            #[inline(always)]
            fn mul(self, rhs: Self) -> Self {
                self * rhs
            }
            /// Swaps ever smaller halves: 16-bit, 8-bit, … 1-bit fields.
            #[inline(always)]
            fn reverse_bits(self) -> Self {
                let mut x = (self >> 16) | (self << 16);
                for (bits, mask) in [
                    (8, 0x00ff_00ffu32),
                    (4, 0x0f0f_0f0f),
                    (2, 0x3333_3333),
                    (1, 0x5555_5555),
                ] {
                    let m = <$t>::splat(mask);
                    x = ((x >> bits) & m) | ((x & m) << bits);
                }
                x
            }
        }
    };
}
word_lanes!(u32x8);
word_lanes!(u32x16);

/// A 32-bit integer hash with good avalanche (Wellons' `lowbias32`).
#[inline]
pub fn hash32(x: u32) -> u32 {
    hash(x)
}

#[inline(always)]
fn hash<W: Word>(mut x: W) -> W {
    x = x ^ (x >> 16);
    x = x.mul(W::splat(0x21f0_aaad));
    x = x ^ (x >> 15);
    x = x.mul(W::splat(0x735a_2d97));
    x ^ (x >> 15)
}

/// One round of [`hash_words`]: folds word `w` into the running hash `h`.
#[inline(always)]
fn hash_combine<W: Word>(h: W, w: W) -> W {
    hash(h ^ w.add(W::splat(0x7f4a_7c15)).add(h << 6).add(h >> 2))
}

/// Where [`hash_words`] starts.
const HASH_START: u32 = 0x9e37_79b9;

/// Hash of several words, order-sensitive.
#[inline]
pub fn hash_words(words: &[u32]) -> u32 {
    words.iter().fold(HASH_START, |h, &w| hash_combine(h, w))
}

/// `hash_words(&[a, b])`, for one stream or eight.
#[inline(always)]
fn hash_pair<W: Word>(a: W, b: W) -> W {
    hash_combine(hash_combine(W::splat(HASH_START), a), b)
}

/// Maps 32 random bits to a float in [0, 1).
#[inline]
pub fn to_unit_float(bits: u32) -> f32 {
    // 24 bits fill the f32 mantissa exactly; the result is < 1.
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// [`to_unit_float`] for eight lanes (exact conversions, so the same values).
#[inline(always)]
fn to_unit_floats(bits: u32x8) -> f32x8 {
    let top: u32x8 = bits >> 8u32;
    let top = i32x8::new(top.to_array().map(|b| b as i32));
    top.round_float() * f32x8::splat(1.0 / 16_777_216.0)
}

/// [`to_unit_floats`] for sixteen lanes.
#[inline(always)]
fn to_unit_floats_x16(bits: u32x16) -> f32x16 {
    let top: u32x16 = bits >> 8u32;
    let top = i32x16::new(top.to_array().map(|b| b as i32));
    top.round_float() * f32x16::splat(1.0 / 16_777_216.0)
}

/// The Laine–Karras permutation: each output bit depends only on the same
/// and lower input bits, so applied to a bit-reversed value it is a nested
/// uniform (Owen) scramble (Burley, "Practical Hash-based Owen
/// Scrambling", 2020).
#[inline(always)]
fn laine_karras<W: Word>(x: W, seed: W) -> W {
    x.add(seed)
        .xor_mul(0x6c50_b47c)
        .xor_mul(0xb82f_1e52)
        .xor_mul(0xc7af_e638)
        .xor_mul(0x8d22_f6e6)
}

/// The first two Sobol dimensions of point `i`, *bit-reversed*: the van der
/// Corput value reversed is `i` itself, and its (0,2)-partner reversed is
/// computed below. Callers Owen-scramble in this reversed domain (where the
/// Laine–Karras permutation works) and reverse once at the end.
///
/// The second dimension's direction numbers are v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1):
/// read as polynomials over GF(2) they are (1 + z)^k, so the point is
/// P(1 + z) for P(z) = Σ bit_k(i)·z^k. Since (1 + z)^(2^m) = 1 + z^(2^m),
/// that substitution is five shift-xor butterflies instead of a loop over
/// the bits of `i` (which are all set after index scrambling).
#[inline(always)]
fn sobol_2d_reversed<W: Word>(i: W) -> (W, W) {
    let mut p = i;
    for (bits, mask) in [
        (1, 0x5555_5555u32),
        (2, 0x3333_3333),
        (4, 0x0f0f_0f0f),
        (8, 0x00ff_00ff),
        (16, 0x0000_ffff),
    ] {
        p = p ^ ((p >> bits) & W::splat(mask));
    }
    (i, p)
}

/// The scrambles of one dimension pair of one pixel.
#[derive(Clone, Copy, Debug)]
struct PairSeeds<W> {
    /// Index shuffle seed.
    index: W,
    /// Scramble seeds of the two coordinates.
    x: W,
    y: W,
}

impl<W: Word> PairSeeds<W> {
    #[inline(always)]
    fn new(key: W, pair: W) -> Self {
        let seed = hash_pair(key, pair);
        PairSeeds {
            index: seed,
            x: hash(seed ^ W::splat(0x1b87_3593)),
            y: hash(seed ^ W::splat(0xcc9e_2d51)),
        }
    }

    /// Point `i` of the pair's sequence, as 32 bits per coordinate.
    #[inline(always)]
    fn point(&self, i: W) -> (W, W) {
        // Shuffle: an Owen scramble of the index (reverse, permute, reverse).
        let index = laine_karras(i.reverse_bits(), self.index).reverse_bits();
        // Scramble each coordinate in the reversed domain, reverse once.
        let (x, y) = sobol_2d_reversed(index);
        (
            laine_karras(x, self.x).reverse_bits(),
            laine_karras(y, self.y).reverse_bits(),
        )
    }
}

/// The random numbers of one camera sample of one pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleStream {
    /// Hash of (seed, pixel): selects the pixel's scrambles.
    key: u32,
    /// The sample index within the pixel.
    sample: u32,
    /// Hash of (key, sample): the base of this sample's independent dimensions.
    base: u32,
    dimension: u32,
    /// Next Sobol dimension pair (pair 0 is the position within the pixel).
    pair: u32,
}

impl SampleStream {
    /// The stream of sample `sample` of pixel `pixel` ([`new_streams`]
    /// makes eight at once, the same).
    pub fn new(seed: u32, pixel: u32, sample: u32) -> Self {
        let key = hash_pair(seed, pixel);
        SampleStream {
            key,
            sample,
            base: hash_pair(key, sample),
            dimension: 0,
            pair: 1,
        }
    }

    /// This sample's point of Sobol dimension pair `pair`: the pixel's
    /// samples in a shuffled order (so pairs do not correlate), each
    /// coordinate Owen-scrambled (so neighbouring pixels do not either).
    fn sobol_pair(&self, pair: u32) -> (f32, f32) {
        PairBlock::new(self.key, pair, self.sample, 1).point(0)
    }

    /// Position within the pixel, in [0, 1)².
    pub fn pixel_offset(&self) -> (f32, f32) {
        self.sobol_pair(0)
    }

    /// The next independent uniform number in [0, 1): one hash of a Weyl
    /// sequence started at this sample's base.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        to_unit_float(self.next_u32())
    }

    /// The next independent 32 random bits: the draw [`next_1d`](Self::next_1d)
    /// makes a number of, whole (for choices among more than 2²⁴ things).
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        self.dimension += 1;
        weyl_hash(self.base, self.dimension)
    }

    /// The next two-dimensional draw, from the next Sobol dimension pair.
    #[inline]
    pub fn next_2d(&mut self) -> (f32, f32) {
        let point = self.sobol_pair(self.pair);
        self.pair += 1;
        point
    }

    /// `count` two-dimensional draws at once from the next dimension pair,
    /// for several samples of the same thing at one path vertex (the `-l`
    /// light samples): draw `j` of this camera sample is point
    /// `sample·count + j` of the pair's sequence, so the first N samples of
    /// a pixel use its first N·`count` points. A prefix of a (0,2)-sequence
    /// is a union of aligned blocks of 2ᵏ points (its length's binary
    /// digits), each a (0,k,2)-net, and the index shuffle maps aligned
    /// blocks to aligned blocks: the pixel's draws are stratified together
    /// for any `count`, and for a power-of-two `count` each sample's own
    /// draws are a net too. (Blocks padded to a power of two, 3 points of
    /// every 4, left a scattered quarter of the net out and measured at
    /// plain Monte Carlo's error, 50× that of `count` = 1 at 1024 samples.)
    /// With `count` = 1 this is exactly [`next_2d`](Self::next_2d).
    #[inline]
    pub fn next_2d_block(&mut self, count: u32) -> PairBlock {
        let first = self.sample.wrapping_mul(block_stride(count));
        let block = PairBlock::new(self.key, self.pair, first, count);
        self.pair += 1;
        block
    }
}

/// Draws of one dimension pair for one camera sample (see
/// [`SampleStream::next_2d_block`]); the scrambles are hashed once for all.
#[derive(Clone, Copy, Debug)]
pub struct PairBlock {
    seeds: PairSeeds<u32>,
    /// Index of the block's first point.
    first: u32,
    count: u32,
}

impl PairBlock {
    #[inline]
    fn new(key: u32, pair: u32, first: u32, count: u32) -> PairBlock {
        PairBlock {
            seeds: PairSeeds::new(key, pair),
            first,
            count,
        }
    }

    /// Draw `j` (< count) of the block.
    #[inline]
    pub fn point(&self, j: u32) -> (f32, f32) {
        debug_assert!(j < self.count.max(1));
        let (x, y) = self.seeds.point(self.first.wrapping_add(j));
        (to_unit_float(x), to_unit_float(y))
    }
}

/// The two-dimensional draws of one path vertex for a whole wave of
/// streams, computed sixteen streams at a time (one AVX-512 register per
/// word; two AVX2 ones elsewhere, as eight at a time were: on the
/// project's AVX-512 hosts this took the stage from 5.1% to 3.5% of a
/// render, PERF.md).
///
/// Scalar, a draw is a chain of ~20 dependent multiplies and shifts that
/// the shading loop waited for twice per vertex; across streams the same
/// chain fills vector lanes. Draw `j` of block `b` of stream `i` is exactly
/// `streams[i].next_2d_block(counts[b]).point(j)` after `b` earlier blocks.
#[derive(Clone, Debug, Default)]
pub struct VertexDraws {
    /// Points per block.
    counts: Vec<u32>,
    /// First slot of each block.
    first_slot: Vec<usize>,
    /// Streams drawn for.
    streams: usize,
    /// Coordinates, slot-major: `u[slot · streams + i]`.
    u: Vec<f32>,
    v: Vec<f32>,
}

impl VertexDraws {
    /// Draws blocks of `counts[b]` points from the next `counts.len()`
    /// dimension pairs of every stream, and moves the streams past them.
    /// Out of line: one call per wave, and inlined into the shading
    /// stage it only moved its own calls there.
    #[inline(never)]
    pub fn draw(&mut self, streams: &mut [SampleStream], counts: impl IntoIterator<Item = u32>) {
        self.counts.clear();
        self.counts.extend(counts);
        self.first_slot.clear();
        let mut slots = 0;
        for &count in &self.counts {
            self.first_slot.push(slots);
            slots += count as usize;
        }
        let n = streams.len();
        self.streams = n;
        // Grow only (waves shrink and refill; see `point` for the layout).
        if self.u.len() < slots * n {
            self.u.resize(slots * n, 0.0);
            self.v.resize(slots * n, 0.0);
        }
        for (chunk, group) in streams.chunks(16).enumerate() {
            let start = chunk * 16;
            let StreamLanes { key, sample, pair } = StreamLanes::<u32x16>::of::<16>(group);
            let mut slot = 0;
            for (b, &count) in self.counts.iter().enumerate() {
                let seeds = PairSeeds::new(key, pair + u32x16::splat(b as u32));
                let first = sample * u32x16::splat(block_stride(count));
                for j in 0..count {
                    let (x, y) = seeds.point(first + u32x16::splat(j));
                    let row = slot * n..(slot + 1) * n;
                    lanes::store_x16(&mut self.u[row.clone()], start, to_unit_floats_x16(x));
                    lanes::store_x16(&mut self.v[row], start, to_unit_floats_x16(y));
                    slot += 1;
                }
            }
        }
        for s in streams {
            s.pair += self.counts.len() as u32;
        }
    }

    /// Draw `j` of block `b` of streams `start..start + 8` (zeros past the end).
    #[inline]
    pub fn lanes(&self, start: usize, b: usize, j: u32) -> (f32x8, f32x8) {
        debug_assert!(j < self.counts[b] && start < self.streams);
        let row = (self.first_slot[b] + j as usize) * self.streams;
        let row = row..row + self.streams;
        (
            lanes::load(&self.u[row.clone()], start),
            lanes::load(&self.v[row], start),
        )
    }

    /// Draw `j` of block `b` of stream `i`.
    #[inline]
    pub fn point(&self, i: usize, b: usize, j: u32) -> (f32, f32) {
        debug_assert!(j < self.counts[b] && i < self.streams);
        let at = (self.first_slot[b] + j as usize) * self.streams + i;
        (self.u[at], self.v[at])
    }
}

/// Dimension `dimension` of the independent draws based at `base`.
#[inline(always)]
fn weyl_hash<W: Word>(base: W, dimension: W) -> W {
    hash(base.add(dimension.mul(W::splat(0x9e37_79b9))))
}

/// [`SampleStream::next_1d`] of the streams picked by `mask` (bit `l`
/// for `streams[l]`), eight at once; the other lanes are unspecified and
/// their streams untouched.
#[inline]
pub fn next_1d_x8(streams: &mut [SampleStream], mask: u32) -> f32x8 {
    let (mut base, mut dimension) = ([0u32; 8], [0u32; 8]);
    for lane in lanes::each(mask) {
        let s = &mut streams[lane];
        s.dimension += 1;
        (base[lane], dimension[lane]) = (s.base, s.dimension);
    }
    to_unit_floats(weyl_hash(u32x8::from(base), u32x8::from(dimension)))
}

/// The counters of up to `N` streams, one per lane (zeros past the end):
/// eight for the camera samples' offsets, sixteen for the wave's draws.
struct StreamLanes<W> {
    key: W,
    sample: W,
    pair: W,
}

impl<W> StreamLanes<W> {
    #[inline(always)]
    fn of<const N: usize>(group: &[SampleStream]) -> StreamLanes<W>
    where
        W: From<[u32; N]>,
    {
        // A full group copies a constant number of lanes, which unrolls
        // into straight-line loads; the run-time length of the tail's loop
        // cost a fifth of the draw stage's time when every group took it.
        let full: Option<&[SampleStream; N]> = group.try_into().ok();
        let field = |f: fn(&SampleStream) -> u32| match full {
            Some(full) => W::from(full.each_ref().map(f)),
            None => {
                let mut a = [0u32; N];
                for (x, s) in a.iter_mut().zip(group) {
                    *x = f(s);
                }
                W::from(a)
            }
        };
        StreamLanes {
            key: field(|s| s.key),
            sample: field(|s| s.sample),
            pair: field(|s| s.pair),
        }
    }
}

/// [`SampleStream::new`] for eight (pixel, sample) pairs at once.
#[inline]
pub fn new_streams(seed: u32, pixels: [u32; 8], samples: [u32; 8]) -> [SampleStream; 8] {
    let key = hash_pair(u32x8::splat(seed), u32x8::from(pixels));
    let base = hash_pair(key, u32x8::from(samples));
    let (key, base) = (key.to_array(), base.to_array());
    std::array::from_fn(|l| SampleStream {
        key: key[l],
        sample: samples[l],
        base: base[l],
        dimension: 0,
        pair: 1,
    })
}

/// [`SampleStream::pixel_offset`] of up to eight streams at once (lanes
/// past `streams.len()` are unspecified).
pub fn pixel_offsets(streams: &[SampleStream]) -> ([f32; 8], [f32; 8]) {
    let StreamLanes { key, sample, .. } = StreamLanes::<u32x8>::of::<8>(streams);
    let (x, y) = PairSeeds::new(key, u32x8::splat(0)).point(sample);
    (to_unit_floats(x).to_array(), to_unit_floats(y).to_array())
}

/// Points of a pair's sequence per camera sample: consecutive blocks, so
/// that a pixel's samples use a prefix of the sequence (see
/// [`SampleStream::next_2d_block`]).
#[inline]
fn block_stride(count: u32) -> u32 {
    count.max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_floats_are_in_range() {
        assert_eq!(to_unit_float(0), 0.0);
        assert!(to_unit_float(u32::MAX) < 1.0);
    }

    /// Strict avalanche (Webster and Tavares): flipping any one input bit
    /// of the hash behind every draw flips each output bit half the time.
    /// A shift turned the wrong way leaves the high input bits no path to
    /// the low output bits (multiplication carries only upward), and
    /// neighbouring counters — pixels, samples, dimensions — would then
    /// share bits of their draws.
    #[test]
    fn hash_avalanches() {
        const N: u32 = 4096;
        let mut flips = [[0u32; 32]; 32];
        let mut x = 0x1234_5678u32;
        for _ in 0..N {
            x = x.wrapping_mul(0x2c1b_3c6d).wrapping_add(0x297a_2d39);
            let h = hash(x);
            for (bit, counts) in flips.iter_mut().enumerate() {
                let changed = h ^ hash(x ^ (1 << bit));
                for (out, count) in counts.iter_mut().enumerate() {
                    *count += (changed >> out) & 1;
                }
            }
        }
        // Each count is Binomial(N, ½): σ = √N / 2 = 32; 6σ is 4.7% of N.
        let bound = 6.0 * (N as f64).sqrt() / 2.0;
        for (bit, counts) in flips.iter().enumerate() {
            for (out, &count) in counts.iter().enumerate() {
                assert!(
                    (count as f64 - N as f64 / 2.0).abs() < bound,
                    "input bit {bit} flips output bit {out} {count} times in {N}"
                );
            }
        }
    }

    #[test]
    fn pixel_offsets_are_stratified_for_power_of_two_prefixes() {
        // A (0,2)-sequence puts exactly one of the first 16 points in each
        // cell of a 4×4 grid, and Owen scrambling preserves that.
        for pixel in 0..50 {
            let mut seen = [false; 16];
            for s in 0..16 {
                let (x, y) = SampleStream::new(7, pixel, s).pixel_offset();
                let cell = (x * 4.0) as usize + 4 * (y * 4.0) as usize;
                assert!(!seen[cell], "pixel {pixel}: cell {cell} twice");
                seen[cell] = true;
            }
        }
    }

    #[test]
    fn successive_dimensions_are_uncorrelated() {
        // Sample correlation of consecutive dimensions over many streams:
        // independent uniforms give ~N(0, 1/n); allow 5 standard deviations.
        let n = 100_000;
        let (mut sxy, mut sx, mut sy, mut sxx, mut syy) = (0.0f64, 0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let mut s = SampleStream::new(3, i % 977, i / 977);
            for _ in 0..(i % 5) {
                s.next_1d();
            }
            let (x, y) = (s.next_1d() as f64, s.next_1d() as f64);
            sxy += x * y;
            sx += x;
            sy += y;
            sxx += x * x;
            syy += y * y;
        }
        let nf = n as f64;
        let cov = sxy / nf - sx / nf * sy / nf;
        let corr = cov / ((sxx / nf - (sx / nf).powi(2)) * (syy / nf - (sy / nf).powi(2))).sqrt();
        assert!(corr.abs() < 5.0 / nf.sqrt(), "correlation {corr}");
    }

    /// The textbook construction: XOR of the direction numbers of the set bits.
    fn sobol_2d_by_direction_numbers(i: u32) -> u32 {
        let (mut y, mut v, mut bits) = (0u32, 1u32 << 31, i);
        while bits != 0 {
            if bits & 1 != 0 {
                y ^= v;
            }
            bits >>= 1;
            v ^= v >> 1;
        }
        y
    }

    #[test]
    fn butterfly_sobol_matches_the_direction_numbers() {
        let mut x = 0x1234_5678u32;
        for i in (0..70_000u32).chain((0..70_000).map(|_| {
            x = hash32(x);
            x
        })) {
            assert_eq!(
                sobol_2d_reversed(i).1.reverse_bits(),
                sobol_2d_by_direction_numbers(i),
                "index {i}"
            );
        }
    }

    #[test]
    fn every_dimension_pair_is_stratified() {
        for pixel in [0u32, 17, 999] {
            for pair in 0..6 {
                let mut seen = [false; 64];
                for s in 0..64 {
                    let mut stream = SampleStream::new(11, pixel, s);
                    for _ in 0..pair {
                        stream.next_2d();
                    }
                    let (x, y) = stream.next_2d();
                    let cell = (x * 8.0) as usize + 8 * (y * 8.0) as usize;
                    assert!(!seen[cell], "pixel {pixel} pair {pair}: cell {cell} twice");
                    seen[cell] = true;
                }
            }
        }
    }

    #[test]
    fn blocks_are_stratified_within_and_across_samples() {
        for (pixel, count) in [(3u32, 4u32), (77, 16), (5, 2)] {
            let samples = 64 / count;
            let mut seen = [false; 64];
            for s in 0..samples {
                let mut stream = SampleStream::new(9, pixel, s);
                stream.next_2d();
                let block = stream.next_2d_block(count);
                // Within one camera sample: `count` points, one per cell of
                // a grid of `count` cells (2×2 for 4, 4×4 for 16, 1×2 or 2×1
                // for 2: the (0,1,2)-net cells are elementary intervals of
                // area 1/2, checked here as halves in x).
                let side = (count as f32).sqrt() as usize;
                let mut own = vec![false; count as usize];
                for j in 0..count {
                    let (x, y) = block.point(j);
                    let cell = if side * side == count as usize {
                        (x * side as f32) as usize + side * (y * side as f32) as usize
                    } else {
                        (x * count as f32) as usize
                    };
                    assert!(!own[cell], "pixel {pixel} sample {s}: cell {cell} twice");
                    own[cell] = true;
                    // Across the pixel: 64 points, one per cell of 8×8.
                    let cell = (x * 8.0) as usize + 8 * (y * 8.0) as usize;
                    assert!(
                        !seen[cell],
                        "pixel {pixel} count {count}: cell {cell} twice"
                    );
                    seen[cell] = true;
                }
            }
        }
    }

    /// Blocks of any count take consecutive points of the pair's
    /// sequence, so a pixel's draws are a prefix: with 3 draws per sample
    /// over 64 samples, the first 128 points and the 64 after them are
    /// each a (0,m,2)-net, one point in every elementary interval
    /// 2⁻ᵃ × 2⁻⁽ᵐ⁻ᵃ⁾. (Padded to blocks of 4, the 192 points used were a
    /// net of 256 with a scattered quarter missing, and this fails.)
    #[test]
    fn blocks_of_any_count_draw_a_prefix_of_the_sequence() {
        for (pixel, count) in [(3u32, 3u32), (40, 5), (8, 6)] {
            let mut points = Vec::new();
            for s in 0..256 / count {
                let mut stream = SampleStream::new(5, pixel, s);
                stream.next_2d();
                let block = stream.next_2d_block(count);
                points.extend((0..count).map(|j| block.point(j)));
            }
            for (start, m) in [(0usize, 7u32), (128, 6)] {
                let net = &points[start..start + (1 << m)];
                for a in 0..=m {
                    let (nx, ny) = (1usize << a, 1usize << (m - a));
                    let mut seen = vec![false; 1 << m];
                    for &(x, y) in net {
                        let cell = (x * nx as f32) as usize + nx * (y * ny as f32) as usize;
                        assert!(
                            !seen[cell],
                            "count {count}: points {start}.. are not a (0,{m},2)-net \
                             ({nx}×{ny} cell {cell} twice)"
                        );
                        seen[cell] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn a_block_of_one_is_next_2d() {
        for s in 0..100 {
            let (mut a, mut b) = (SampleStream::new(2, 8, s), SampleStream::new(2, 8, s));
            for _ in 0..3 {
                assert_eq!(a.next_2d(), b.next_2d_block(1).point(0));
            }
        }
    }

    #[test]
    fn batched_draws_are_the_scalar_draws() {
        // Streams in groups of sixteen: a partial group alone (5), one
        // shorter than eight (21 = 16 + 5) and one longer (27 = 16 + 11),
        // so both halves of a group's stores meet a tail.
        for n in [5, 21, 27] {
            batched_draws_match(n);
        }
    }

    /// [`batched_draws_are_the_scalar_draws`] for `n` streams.
    fn batched_draws_match(n: u32) {
        // Streams at different pairs and samples (large ones, so indices
        // wrap). The waves ask for 3, then 25, then 2 draws per stream, so
        // the buffers must grow between the first two.
        let waves: [&[u32]; 3] = [&[1, 2], &[1, 4, 3, 1, 16], &[2]];
        let mut streams: Vec<SampleStream> = (0..n)
            .map(|i| {
                let mut s = SampleStream::new(21, 1000 + i, i.wrapping_mul(0x1357_9bdf));
                for _ in 0..i % 3 {
                    s.next_2d();
                }
                s
            })
            .collect();
        let mut expected = streams.clone();
        let mut draws = VertexDraws::default();
        for counts in waves {
            draws.draw(&mut streams, counts.iter().copied());
            for (i, stream) in expected.iter_mut().enumerate() {
                for (b, &count) in counts.iter().enumerate() {
                    let block = stream.next_2d_block(count);
                    for j in 0..count {
                        assert_eq!(
                            draws.point(i, b, j),
                            block.point(j),
                            "stream {i} block {b} draw {j}"
                        );
                        let (u, v) = draws.lanes(i / 8 * 8, b, j);
                        let lane = i % 8;
                        assert_eq!((u.as_array()[lane], v.as_array()[lane]), block.point(j));
                    }
                }
                assert_eq!(stream.pair, streams[i].pair);
            }
        }
    }

    #[test]
    fn batched_1d_draws_are_the_scalar_draws() {
        // Streams at different dimensions; only the masked lanes draw.
        let mut streams: Vec<SampleStream> = (0..8u32)
            .map(|i| {
                let mut s = SampleStream::new(5, 30 + i, i * 77);
                for _ in 0..i {
                    s.next_1d();
                }
                s
            })
            .collect();
        let mut expected = streams.clone();
        for mask in [0xffu32, 0b1010_0110, 0b1, 0] {
            let x = next_1d_x8(&mut streams, mask);
            for (lane, e) in expected.iter_mut().enumerate() {
                if mask & (1 << lane) != 0 {
                    assert_eq!(x.as_array()[lane], e.next_1d(), "lane {lane}");
                }
                assert_eq!(streams[lane].dimension, e.dimension, "lane {lane}");
            }
        }
    }

    #[test]
    fn batched_streams_are_the_scalar_ones() {
        for seed in [0, 7, u32::MAX] {
            let pixels: [u32; 8] = std::array::from_fn(|l| (l as u32 * 1001).wrapping_add(seed));
            let samples: [u32; 8] = std::array::from_fn(|l| (l as u32).wrapping_mul(0x9e37_79b9));
            let streams = new_streams(seed, pixels, samples);
            for l in 0..8 {
                let one = SampleStream::new(seed, pixels[l], samples[l]);
                let fields = |s: &SampleStream| (s.key, s.sample, s.base, s.dimension, s.pair);
                assert_eq!(fields(&streams[l]), fields(&one), "seed {seed} lane {l}");
            }
        }
    }

    #[test]
    fn batched_pixel_offsets_are_the_scalar_ones() {
        let streams: Vec<SampleStream> = (0..11u32)
            .map(|i| SampleStream::new(4, 7 * i, i.wrapping_mul(0x9e37_79b9)))
            .collect();
        for group in streams.chunks(8) {
            let (x, y) = pixel_offsets(group);
            for (k, s) in group.iter().enumerate() {
                assert_eq!((x[k], y[k]), s.pixel_offset());
            }
        }
    }

    #[test]
    fn dimension_pairs_are_not_correlated() {
        // Across a pixel's samples, x of pair k and x of pair k+1 must not
        // be correlated (a shared index order would make them equal).
        let n = 4096;
        let (mut sxy, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
        for s in 0..n {
            let mut stream = SampleStream::new(5, 42, s);
            let (a, _) = stream.next_2d();
            let (b, _) = stream.next_2d();
            sxy += (a * b) as f64;
            sx += a as f64;
            sy += b as f64;
        }
        let nf = n as f64;
        let corr = (sxy / nf - sx / nf * sy / nf) * 12.0;
        assert!(corr.abs() < 5.0 / nf.sqrt(), "correlation {corr}");
    }

    #[test]
    fn streams_are_uniform() {
        // Mean and variance of U[0,1): 1/2 and 1/12, within 5 standard errors.
        let n = 200_000;
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let mut s = SampleStream::new(1, i % 1000, i / 1000);
            let x = s.next_1d() as f64;
            s1 += x;
            s2 += x * x;
        }
        let mean = s1 / n as f64;
        let var = s2 / n as f64 - mean * mean;
        let se = (1.0f64 / 12.0 / n as f64).sqrt();
        assert!((mean - 0.5).abs() < 5.0 * se, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 0.002, "variance {var}");
    }
}
