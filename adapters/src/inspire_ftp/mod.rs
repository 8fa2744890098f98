//! Inspire FTP (RH56DFTP, tactile) hand: mapping table, DDS client codec (of Inspire's DDS
//! driver, one per hand), the driver's emulator with the tactile arrays, and the front of the
//! driver's own interface (codec `front`, registry entry and endpoints `serve`). Facts: docs/sources.md §7 ("Inspire FTP").

pub mod adapter;
pub mod config;
pub mod emulator;
pub mod front;
pub mod kind;
pub mod serve;
pub mod table;
