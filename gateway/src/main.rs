use clap::Parser;

fn main() -> anyhow::Result<()> {
    let cli = handgate_gateway::cli::Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .init();
    match cli.command {
        handgate_gateway::cli::Command::Run { domain } => {
            let node = handgate_adapters::dds::Node::new(domain, None)?;
            tracing::info!(domain = node.domain_id(), "handgate started (no devices yet)");
            let rt = tokio::runtime::Runtime::new()?;
            rt.block_on(async { tokio::signal::ctrl_c().await })?;
            tracing::info!("stopped");
        }
    }
    Ok(())
}
