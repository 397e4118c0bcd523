//! `cubist serve`: the long-running renderer, reading requests on stdin and replying on stdout.

use crate::cli::ServeArgs;
use crate::error::Result;

/// Serves until `shutdown`, the end of stdin, or the parent's death.
pub fn serve(args: ServeArgs) -> Result<()> {
    let options = crate::serve::Options { budget: args.cache_memory << 20, parent: args.parent, ..Default::default() };
    let stdin = std::io::stdin().lock();
    crate::serve::serve(stdin, Box::new(std::io::stdout()), options)
}
