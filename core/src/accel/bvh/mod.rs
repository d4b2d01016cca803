//! PLACEHOLDER: the default BVH (being written).
