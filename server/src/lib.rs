//! jink's service: HTTP API, wire formats, geodesy, storage and CLI.
