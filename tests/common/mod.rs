#![allow(dead_code)]
pub mod scenes;
