//! `jink token create|list|revoke`: the access tokens of a database (see [`crate::auth`]).
//! They act on the database directly, so every replica sharing it sees the change (within
//! `--token-cache-s` of `jink serve`).

use std::process::ExitCode;

use clap::{Args, Subcommand};

use crate::auth::{Role, digest, new_token};
use crate::store::Store;
use crate::store::tokens::CreateTokenError;
use crate::time::{format_rfc3339, now_s};

/// Flags of `jink token`.
#[derive(Debug, Args)]
pub struct TokenArgs {
    /// Database URL, as for `jink serve`.
    #[arg(
        long,
        env = "JINK_DATABASE_URL",
        default_value = "sqlite://jink.sqlite",
        global = true
    )]
    pub database_url: String,

    /// What to do.
    #[command(subcommand)]
    pub command: TokenCommand,
}

/// The token subcommands.
#[derive(Debug, Subcommand)]
pub enum TokenCommand {
    /// Create a token and print it once (only its SHA-256 digest is stored).
    Create {
        /// Its name: recorded as the writer of everything it stores; never reused.
        #[arg(long)]
        name: String,
        /// `read` (GET), `write` (also telemetry, obstacles, plans) or `admin` (also
        /// missions and tokens).
        #[arg(long, value_enum)]
        role: Role,
    },
    /// List the tokens (name, role, created, revoked), never their text.
    List,
    /// Revoke the token NAME: it stops working on every replica within the token cache
    /// time of `jink serve` (2 s by default).
    Revoke {
        /// The token's name.
        name: String,
    },
}

/// A valid token name: 1 to 64 of letters, digits, `-`, `_`, `.`, `@`, and not `local`.
fn valid_name(name: &str) -> bool {
    (1..=64).contains(&name.len())
        && name != crate::auth::LOCAL
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.' | '@'))
}

/// Runs `jink token ...`.
pub fn run(args: TokenArgs) -> ExitCode {
    let Some(rt) = super::runtime(tokio::runtime::Builder::new_current_thread()) else {
        return ExitCode::FAILURE;
    };
    rt.block_on(async move {
        let store = match Store::open(&args.database_url).await {
            Ok(s) => s,
            Err(e) => {
                eprintln!("jink: {e}");
                return ExitCode::FAILURE;
            }
        };
        let code = match args.command {
            TokenCommand::Create { name, role } => {
                if !valid_name(&name) {
                    eprintln!(
                        "jink: invalid token name '{name}': use 1 to 64 letters, digits, '-', '_', '.', '@' (and not 'local')"
                    );
                    return ExitCode::FAILURE;
                }
                let token = new_token();
                match store
                    .create_token(&name, role.as_str(), &digest(&token), now_s())
                    .await
                {
                    Ok(()) => {
                        println!("{token}");
                        eprintln!(
                            "jink: token '{name}' ({}) created; it is shown only this once. Send it as: Authorization: Bearer <token>",
                            role.as_str()
                        );
                        ExitCode::SUCCESS
                    }
                    Err(e @ CreateTokenError::NameTaken(_)) => {
                        eprintln!("jink: {e}");
                        ExitCode::FAILURE
                    }
                    Err(CreateTokenError::Db(e)) => {
                        eprintln!("jink: cannot store the token: {e}");
                        ExitCode::FAILURE
                    }
                }
            }
            TokenCommand::List => match store.list_tokens().await {
                Ok(rows) => {
                    println!("{:<24} {:<6} {:<21} revoked", "name", "role", "created");
                    for r in rows {
                        println!(
                            "{:<24} {:<6} {:<21} {}",
                            r.name,
                            r.role,
                            format_rfc3339(r.created_at_s.floor()),
                            r.revoked_at_s
                                .map_or_else(|| "-".to_string(), |t| format_rfc3339(t.floor()))
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("jink: cannot read the tokens: {e}");
                    ExitCode::FAILURE
                }
            },
            TokenCommand::Revoke { name } => match store.revoke_token(&name, now_s()).await {
                Ok(true) => {
                    eprintln!("jink: token '{name}' revoked");
                    ExitCode::SUCCESS
                }
                Ok(false) => {
                    eprintln!("jink: no valid token is named '{name}' (see `jink token list`)");
                    ExitCode::FAILURE
                }
                Err(e) => {
                    eprintln!("jink: cannot revoke: {e}");
                    ExitCode::FAILURE
                }
            },
        };
        store.close().await;
        code
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn token_names_are_plain_and_never_local() {
        assert!(super::valid_name("gcs-1"));
        assert!(super::valid_name("ops@field.a"));
        assert!(!super::valid_name("local"));
        assert!(!super::valid_name(""));
        assert!(!super::valid_name("a b"));
        assert!(!super::valid_name(&"x".repeat(65)));
    }
}
