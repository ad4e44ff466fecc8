//! Transforms, clipping, scan conversion and the Z-buffer (work in progress).
