//! Film (being written).
