//! Planar Euler–Bernoulli finite-element beam (filled by issue 4).
