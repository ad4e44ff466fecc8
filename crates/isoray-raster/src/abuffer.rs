//! A-buffer: fragments with 4×8 coverage masks (work in progress).
