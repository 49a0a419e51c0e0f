//! Placeholder until the image module lands.
pub mod io;
use crate::math::Vec3;
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}
impl Image {
    pub fn new(width: u32, height: u32, pixels: Vec<Vec3>) -> Self {
        Self {
            width,
            height,
            pixels,
        }
    }
}
