//! Completes the generated OpenAPI document where utoipa's derives cannot say enough.
//!
//! Contract (checked by `server/tests/openapi.rs` and by `.ci/run` with
//! openapi-spec-validator, schemathesis and openapi-python-client):
//! - every operation lists the statuses the shared extractors can answer, each with the
//!   problem schema: 400 when it takes a query parameter (unparseable value) or a body
//!   (malformed JSON), 413/415/422 when it takes a JSON body, 404 when its path names a
//!   mission;
//! - `Mission` is one flat object (openapi-python-client cannot merge the `allOf` of the
//!   derived schema, whose `home` is optional in the input and required in the output);
//! - `WireTime` is typed: an RFC 3339 string or Unix seconds;
//! - `POST /api/v1/missions` links to every mission-scoped operation by the created id.

use serde_json::{Map, Value, json};

use crate::error::PROBLEM_JSON;

/// Applies every completion to `doc` (the document as JSON).
pub fn complete(doc: &mut Value) {
    flatten_mission(doc);
    type_wire_time(doc);
    add_error_statuses(doc);
    add_mission_links(doc);
}

fn problem(description: &str) -> Value {
    json!({
        "description": description,
        "content": { PROBLEM_JSON: { "schema": { "$ref": "#/components/schemas/Problem" } } }
    })
}

/// `Mission` = `allOf[MissionInput, {id, source_format, created_at, home}]` becomes one
/// object with the union of the properties (the second part's win) and of the required
/// names.
fn flatten_mission(doc: &mut Value) {
    let schemas = &mut doc["components"]["schemas"];
    let Some(parts) = schemas["Mission"]["allOf"].as_array().cloned() else {
        return;
    };
    let mut properties = Map::new();
    let mut required: Vec<Value> = Vec::new();
    for part in &parts {
        let part = match part.get("$ref").and_then(Value::as_str) {
            Some(r) => schemas[r.trim_start_matches("#/components/schemas/")].clone(),
            None => part.clone(),
        };
        if let Some(props) = part["properties"].as_object() {
            for (k, v) in props {
                properties.insert(k.clone(), v.clone());
            }
        }
        for name in part["required"].as_array().into_iter().flatten() {
            if !required.contains(name) {
                required.push(name.clone());
            }
        }
    }
    let description = schemas["Mission"]["description"].clone();
    schemas["Mission"] = json!({
        "type": "object",
        "description": description,
        "required": required,
        "properties": properties,
    });
}

fn type_wire_time(doc: &mut Value) {
    let t = &mut doc["components"]["schemas"]["WireTime"];
    if t.is_object() && t.get("type").is_none() && t.get("oneOf").is_none() {
        t["oneOf"] = json!([
            { "type": "string", "format": "date-time", "description": "RFC 3339" },
            { "type": "number", "description": "Unix seconds" }
        ]);
    }
}

fn add_error_statuses(doc: &mut Value) {
    let Some(paths) = doc["paths"].as_object_mut() else {
        return;
    };
    for (path, ops) in paths.iter_mut() {
        let Some(ops) = ops.as_object_mut() else {
            continue;
        };
        for op in ops.values_mut() {
            let has_query = op["parameters"]
                .as_array()
                .is_some_and(|ps| ps.iter().any(|p| p["in"] == "query"));
            let has_body = op.get("requestBody").is_some();
            let mut add = |status: &str, description: &str| {
                let responses = &mut op["responses"];
                if responses.get(status).is_none() {
                    responses[status] = problem(description);
                }
            };
            if has_query {
                add(
                    "400",
                    "A query parameter could not be parsed; `errors` names it",
                );
            }
            if has_body {
                add("400", "Malformed JSON or a field of the wrong type");
                add("413", "Body larger than the limit");
                add("415", "Not a JSON body");
                add("422", "Invalid field, named by a JSON pointer");
            }
            if path.starts_with("/api/v1/missions/{id}") {
                add("404", "No such mission");
            }
        }
    }
}

/// Links from the 201 of `POST /api/v1/missions` to every operation whose path starts
/// with `/api/v1/missions/{id}` and takes no other path parameter.
fn add_mission_links(doc: &mut Value) {
    let mut links = Map::new();
    if let Some(paths) = doc["paths"].as_object() {
        for (path, ops) in paths {
            if !path.starts_with("/api/v1/missions/{id}") || path.matches('{').count() != 1 {
                continue;
            }
            for (method, op) in ops.as_object().into_iter().flatten() {
                let Some(op_id) = op["operationId"].as_str() else {
                    continue;
                };
                links.insert(
                    op_id.to_string(),
                    json!({
                        "operationId": op_id,
                        "parameters": { "id": "$response.body#/id" },
                        "description": format!("{} {path} for the created mission", method.to_uppercase()),
                    }),
                );
            }
        }
    }
    let created = &mut doc["paths"]["/api/v1/missions"]["post"]["responses"]["201"];
    if created.is_object() && !links.is_empty() {
        created["links"] = Value::Object(links);
    }
}
