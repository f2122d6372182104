//! base params
