//! Standard mechanisms built in code: the benchmark and test problems with known structure;
//! and [`SplitMix64`], the one seeded random generator of the workspace's tests and
//! benchmarks (deterministic on every platform, no external RNG crate).

use crate::model::{Axis, Body, Joint, JointKind, Model, Parameter, Point, Scalar, SourceInfo};

fn num(v: f64) -> Scalar {
    Scalar::Num(v)
}

fn zero3() -> [Scalar; 3] {
    [Scalar::ZERO, Scalar::ZERO, Scalar::ZERO]
}

fn empty_model(name: &str, gravity: [f64; 3]) -> Model {
    Model {
        name: name.into(),
        source: SourceInfo {
            path: format!("<sample {name}>"),
            hash: String::new(),
        },
        parameters: Vec::<Parameter>::new(),
        gravity: gravity.map(num),
        bodies: vec![],
        points: vec![],
        forces: vec![],
        constraints: vec![],
    }
}

/// A planar chain of `n` identical uniform slender rods (length 1 m, mass 1 kg) pivoted about
/// z, each lying along its body x axis, under gravity `-9.81 y`; all parameters numeric (folded).
/// A point `tip` sits at the free end of the last rod.
pub fn planar_chain(n: usize) -> Model {
    let (l, m) = (1.0, 1.0);
    let mut model = empty_model(&format!("planar_chain_{n}"), [0.0, -9.81, 0.0]);
    for i in 0..n {
        let mut inertia: [[Scalar; 3]; 3] = [zero3(), zero3(), zero3()];
        inertia[1][1] = num(m * l * l / 12.0);
        inertia[2][2] = num(m * l * l / 12.0);
        model.bodies.push(Body {
            name: format!("rod{}", i + 1),
            coordinate: format!("q{}", i + 1),
            parent: i.checked_sub(1),
            joint: Joint {
                kind: JointKind::Revolute,
                axis: Axis::Z,
                anchor: [
                    num(if i == 0 { 0.0 } else { l }),
                    Scalar::ZERO,
                    Scalar::ZERO,
                ],
                rotation: vec![],
            },
            mass: num(m),
            com: [num(l / 2.0), Scalar::ZERO, Scalar::ZERO],
            inertia,
        });
    }
    model.points.push(Point {
        name: "tip".into(),
        body: n.checked_sub(1),
        position: [num(l), Scalar::ZERO, Scalar::ZERO],
    });
    model
}

/// A spatial chain of `n` bodies whose revolute joints cycle through the axes z, x, y (every
/// fourth joint prismatic along the local x axis), with off-axis centres of mass, full inertia
/// tensors and gravity `-9.81 z`; all parameters numeric.
pub fn spatial_chain(n: usize) -> Model {
    let mut model = empty_model(&format!("spatial_chain_{n}"), [0.0, 0.0, -9.81]);
    for i in 0..n {
        let axis = [Axis::Z, Axis::X, Axis::Y][i % 3];
        let kind = if i % 4 == 3 {
            JointKind::Prismatic
        } else {
            JointKind::Revolute
        };
        let k = i as f64;
        // A valid full inertia tensor: principal moments (0.02, 0.03, 0.04) rotated about z
        // by 0.3 rad: off-diagonal xy term only, eigenvalues unchanged.
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let (a, b) = (0.02, 0.03);
        let ixx = c * c * a + s * s * b;
        let iyy = s * s * a + c * c * b;
        let ixy = c * s * (a - b);
        let inertia = [
            [num(ixx), num(ixy), Scalar::ZERO],
            [num(ixy), num(iyy), Scalar::ZERO],
            [Scalar::ZERO, Scalar::ZERO, num(0.04)],
        ];
        model.bodies.push(Body {
            name: format!("b{}", i + 1),
            coordinate: format!("q{}", i + 1),
            parent: i.checked_sub(1),
            joint: Joint {
                kind,
                axis: if kind == JointKind::Prismatic {
                    Axis::X
                } else {
                    axis
                },
                anchor: if i == 0 {
                    zero3()
                } else {
                    [num(0.3), num(0.05), Scalar::ZERO]
                },
                rotation: vec![],
            },
            mass: num(1.0 + 0.1 * k),
            com: [num(0.15), num(0.02), num(-0.01)],
            inertia,
        });
    }
    model.points.push(Point {
        name: "tip".into(),
        body: n.checked_sub(1),
        position: [num(0.3), Scalar::ZERO, Scalar::ZERO],
    });
    model
}

/// SplitMix64 (Steele, Lea, Flood 2014): a tiny, fast, well-mixed 64-bit generator, the one
/// seeded generator of the tests and benchmarks: the same seed gives the same sequence on
/// every platform.
///
/// ```
/// use mbs_symbolic::samples::SplitMix64;
/// let mut rng = SplitMix64::new(7);
/// let x = rng.uniform(-1.0, 2.0);
/// assert!((-1.0..2.0).contains(&x));
/// assert_eq!(SplitMix64::new(7).uniform(-1.0, 2.0), x);
/// ```
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator with the given seed.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` (53 random bits).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// Uniform in `[-scale, scale)`: `scale (2 u - 1)` with `u` from [`next_f64`](Self::next_f64).
    pub fn symmetric(&mut self, scale: f64) -> f64 {
        scale * (self.next_f64() * 2.0 - 1.0)
    }

    /// `N` values of [`symmetric`](Self::symmetric)`(scale)`.
    pub fn array<const N: usize>(&mut self, scale: f64) -> [f64; N] {
        std::array::from_fn(|_| self.symmetric(scale))
    }

    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// `true` with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.next_f64() < p
    }

    /// A uniformly chosen coordinate axis.
    pub fn axis(&mut self) -> Axis {
        [Axis::X, Axis::Y, Axis::Z][self.below(3)]
    }
}

#[cfg(test)]
mod rng_tests {
    use super::SplitMix64;

    /// The first outputs for seed 0, from the reference implementation (Vigna's
    /// `splitmix64.c`).
    #[test]
    fn splitmix64_matches_the_reference_sequence() {
        let mut rng = SplitMix64::new(0);
        assert_eq!(rng.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(rng.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(rng.next_u64(), 0x06C4_5D18_8009_454F);
    }

    #[test]
    fn floats_stay_in_their_ranges() {
        let mut rng = SplitMix64::new(42);
        for _ in 0..1000 {
            let u = rng.next_f64();
            assert!((0.0..1.0).contains(&u));
            let s = rng.symmetric(3.0);
            assert!((-3.0..3.0).contains(&s));
            assert!(rng.below(5) < 5);
        }
    }
}
