//! Helpers shared by the scene crate's tests: parsing snippets of the candela language and
//! loading snippets of Mitsuba XML, with their errors as `line:col: message`.
#![allow(dead_code)]

pub mod lang;
pub mod mitsuba;
