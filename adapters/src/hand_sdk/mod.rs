pub mod adapter;
pub mod table;
