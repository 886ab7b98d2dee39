//! Navigation core: the WGS-84 Earth at a fixed site, attitude algebra and
//! the strapdown mechanization on increments. No I/O happens here.

pub mod attitude;
pub mod earth;
pub mod strapdown;

pub use earth::Site;
pub use strapdown::Strapdown;
