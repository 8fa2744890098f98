pub mod dds_client;
pub mod table;
