//! Inspire FTP (RH56DFTP, tactile) hand: mapping table, DDS client codec (of Inspire's DDS
//! driver, one per hand), the driver's emulator with the tactile arrays, and the front codec of
//! the driver's own interface. Facts: docs/sources.md §7 ("Inspire FTP").

pub mod adapter;
pub mod emulator;
pub mod front;
pub mod kind;
pub mod open;
pub mod table;
