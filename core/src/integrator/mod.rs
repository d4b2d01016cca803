//! Integrators (being written).
