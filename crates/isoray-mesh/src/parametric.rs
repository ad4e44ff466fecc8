//! Tessellation of parametric surfaces over their (s, t) domain (work in progress).
