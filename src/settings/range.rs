//! An interval of numbers a setting accepts, and how messages and the schema write it.

/// An interval of numbers: [min, max], either end open when its flag says so, `max` None for
/// no upper bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: Option<f64>,
    pub min_exclusive: bool,
    pub max_exclusive: bool,
}

impl Range {
    /// [min, max].
    pub const fn closed(min: f64, max: f64) -> Range {
        Range { min, max: Some(max), min_exclusive: false, max_exclusive: false }
    }
    /// [min, infinity).
    pub const fn at_least(min: f64) -> Range {
        Range { min, max: None, min_exclusive: false, max_exclusive: false }
    }
    /// (min, infinity).
    pub const fn above(min: f64) -> Range {
        Range { min, max: None, min_exclusive: true, max_exclusive: false }
    }
    pub const fn open_min(self) -> Range {
        Range { min_exclusive: true, ..self }
    }
    pub const fn open_max(self) -> Range {
        Range { max_exclusive: true, ..self }
    }
    /// Whether `v` is in the range (NaN never is).
    pub fn contains(&self, v: f64) -> bool {
        let above = if self.min_exclusive { v > self.min } else { v >= self.min };
        let below = match self.max {
            Some(max) if self.max_exclusive => v < max,
            Some(max) => v <= max,
            None => !v.is_nan(),
        };
        above && below
    }
}

/// The interval as messages write it: `[0, 1]`, `(0, 1000]`, `[1, inf)`.
impl std::fmt::Display for Range {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let open = if self.min_exclusive { '(' } else { '[' };
        let min = crate::error::short_num(self.min);
        match self.max {
            Some(max) => {
                let close = if self.max_exclusive { ')' } else { ']' };
                write!(f, "{open}{min}, {}{close}", crate::error::short_num(max))
            }
            None => write!(f, "{open}{min}, inf)"),
        }
    }
}
