//! Mesh files: binary STL, OBJ, PLY and glTF binary (work in progress).
