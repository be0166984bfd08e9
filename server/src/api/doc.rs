//! Completes the generated OpenAPI document where utoipa's derives cannot say enough.
//!
//! Contract (checked by `server/tests/openapi.rs` and by `.ci/run` with
//! openapi-spec-validator, schemathesis and openapi-python-client):
//! - every operation lists the statuses the shared extractors can answer, each with the
//!   problem schema: 400 when it takes a query parameter (unparseable value) or a body
//!   (malformed JSON), 413/415/422 when it takes a JSON body, 404 when its path names a
//!   mission (or a mission and a plan); an operation states only what it answers beyond
//!   these, or a more specific description;
//! - `Mission` is one flat object (openapi-python-client cannot merge the `allOf` of the
//!   derived schema, whose `home` is optional in the input and required in the output);
//! - `WireTime` is typed: an RFC 3339 string or Unix seconds;
//! - image responses are binary strings;
//! - array items carry their constraints (`scan_radii_m` of the offset request: in (0, 1e6]);
//! - `POST /api/v1/missions` links to every mission-scoped operation by the created id;
//! - its request body is a `oneOf` naming each accepted format: native, interop 2017/2018
//!   (one mission or the `GET /api/missions` list) and interop 2019+ protobuf-JSON. The
//!   interop schemas describe the judges' documents (feet, knots) and allow extra members,
//!   as the adapters ignore the parts jink does not use.

use serde_json::{Map, Value, json};

use crate::error::PROBLEM_JSON;

/// Applies every completion to `doc` (the document as JSON).
pub fn complete(doc: &mut Value) {
    flatten_mission(doc);
    describe_mission_formats(doc);
    type_wire_time(doc);
    add_error_statuses(doc);
    add_mission_links(doc);
    constrain_array_items(doc);
    binary_images(doc);
    add_access(doc);
    crate::interop::api::complete_doc(doc);
}

/// Access (issue 12): the bearer scheme, declared optional globally (`{}` or `bearer`: a
/// loopback bind takes requests without a token; any other bind requires one), and the
/// statuses the guard and the overload limits answer: 401/403 on every operation but
/// `GET /healthz`, 429 on writes, 503 (request timeout, full plan pool) everywhere.
fn add_access(doc: &mut Value) {
    doc["components"]["securitySchemes"]["bearer"] = json!({
        "type": "http",
        "scheme": "bearer",
        "description": "A token from `jink token create --name NAME --role read|write|admin`. \
    Required on every request but GET /healthz when jink is bound to a non-loopback address (or run with --auth on); \
    optional on loopback. `read` may GET, `write` may also post telemetry, obstacles and plans, `admin` may also create and delete missions."
    });
    doc["security"] = json!([{}, {"bearer": []}]);
    for schema in ["Mission", "ObservationOut", "AircraftTelemetryOut"] {
        let props = &mut doc["components"]["schemas"][schema]["properties"];
        if props.is_object() {
            props["written_by"] = json!({
                "type": "string",
                "description": "The name of the token that stored it, or `local` (no token: a loopback client, or --auth off)"
            });
        }
    }
    let Some(paths) = doc["paths"].as_object_mut() else {
        return;
    };
    for (path, ops) in paths.iter_mut() {
        let Some(ops) = ops.as_object_mut() else {
            continue;
        };
        for (method, op) in ops.iter_mut() {
            let mut add = |status: &str, description: &str| {
                let responses = &mut op["responses"];
                if responses.get(status).is_none() {
                    responses[status] = problem(description);
                }
            };
            if path == "/healthz" {
                add(
                    "503",
                    "The request timed out (`Retry-After` says when to retry)",
                );
                continue;
            }
            add(
                "401",
                "No token, or a token that is unknown or revoked, where one is required",
            );
            add("403", "The token's role does not allow this operation");
            if method != "get" {
                add(
                    "429",
                    "The token's write rate is exhausted; `Retry-After` says when to retry",
                );
            }
            add(
                "503",
                "The plan pool is full or the request timed out; `Retry-After` says when to retry",
            );
        }
    }
}

/// Image responses are binary strings (utoipa describes a `Vec<u8>` body as an array of
/// integers).
fn binary_images(doc: &mut Value) {
    let Some(paths) = doc["paths"].as_object_mut() else {
        return;
    };
    let responses = paths
        .values_mut()
        .filter_map(Value::as_object_mut)
        .flat_map(|ops| ops.values_mut())
        .filter_map(|op| op.get_mut("responses").and_then(Value::as_object_mut))
        .flat_map(|rs| rs.values_mut());
    for resp in responses {
        let Some(content) = resp.get_mut("content").and_then(Value::as_object_mut) else {
            continue;
        };
        for (media, c) in content.iter_mut() {
            if media.starts_with("image/") {
                c["schema"] = json!({"type": "string", "format": "binary"});
            }
        }
    }
}

/// Item constraints the derives cannot attach to a `Vec<f64>`'s items.
fn constrain_array_items(doc: &mut Value) {
    let radii = &mut doc["components"]["schemas"]["OffsetRequest"]["properties"]["scan_radii_m"];
    if radii.is_object() {
        radii["items"]["exclusiveMinimum"] = json!(0);
        radii["items"]["maximum"] = json!(1_000_000);
    }
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
            match (has_query, has_body) {
                (true, true) => add(
                    "400",
                    "Malformed JSON, a field of the wrong type or a query parameter that could not be parsed; `errors` names it when known",
                ),
                (true, false) => add(
                    "400",
                    "A query parameter could not be parsed; `errors` names it",
                ),
                (false, true) => add("400", "Malformed JSON or a field of the wrong type"),
                (false, false) => {}
            }
            if has_body {
                add("413", "Body larger than the limit");
                add("415", "Not a JSON body");
                add("422", "Invalid field, named by a JSON pointer");
            }
            if path.contains("{plan_id}") {
                add("404", "No such mission or plan");
            } else if path.starts_with("/api/v1/missions/{id}") {
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

fn latlon(lat: &str, lon: &str, extra: &[(&str, Value)]) -> Value {
    let mut props = Map::new();
    props.insert(lat.into(), json!({"type": "number", "minimum": -90, "maximum": 90, "description": "Latitude, degrees"}));
    props.insert(lon.into(), json!({"type": "number", "minimum": -180, "maximum": 180, "description": "Longitude, degrees"}));
    let mut required = vec![json!(lat), json!(lon)];
    for (k, v) in extra {
        props.insert((*k).into(), v.clone());
        required.push(json!(k));
    }
    json!({"type": "object", "required": required, "properties": props})
}

/// A number in feet MSL (`what` names it).
fn feet(what: &str) -> Value {
    json!({"type": "number", "description": format!("{what}, feet MSL")})
}

/// An interop mission document: an integer `id` and `properties`; extra members are
/// allowed, as the adapters ignore the parts jink does not use.
fn interop_mission(title: &str, description: &str, required: &[&str], properties: Value) -> Value {
    let mut props = Map::new();
    props.insert("id".into(), json!({"type": "integer"}));
    props.extend(properties.as_object().cloned().unwrap_or_default());
    json!({
        "type": "object",
        "title": title,
        "description": description,
        "required": required,
        "properties": props,
        "additionalProperties": true,
    })
}

/// An interop fly-zone list (at least one): each zone a boundary of at least 3 `point`s and
/// a floor and ceiling in feet, under the names `[boundary, floor, ceiling]`.
fn fly_zones([boundary, floor, ceiling]: [&str; 3], point: Value) -> Value {
    json!({"type": "array", "minItems": 1, "items": {
        "type": "object",
        "required": [boundary, floor, ceiling],
        "properties": {
            boundary: {"type": "array", "minItems": 3, "items": point},
            floor: feet("Floor"),
            ceiling: feet("Ceiling"),
        }
    }})
}

/// The interop mission schemas and the `oneOf` body of `POST /api/v1/missions`.
fn describe_mission_formats(doc: &mut Value) {
    let interop_2018 = interop_mission(
        "Interop2018Mission",
        "Format `interop-2018`: an interop server 2017/2018 mission (`GET /api/missions/{id}`), feet.",
        &["fly_zones", "mission_waypoints"],
        json!({
            "active": {"type": "boolean"},
            "home_pos": latlon("latitude", "longitude", &[]),
            "fly_zones": fly_zones(
                ["boundary_pts", "altitude_msl_min", "altitude_msl_max"],
                latlon("latitude", "longitude", &[("order", json!({"type": "integer"}))]),
            ),
            "mission_waypoints": {"type": "array", "items": latlon("latitude", "longitude", &[
                ("altitude_msl", feet("Altitude")), ("order", json!({"type": "integer"}))
            ])},
        }),
    );
    let interop_2019 = interop_mission(
        "Interop2019Mission",
        "Format `interop-2019`: an interop server 2019+ protobuf-JSON mission (camelCase; snake_case keys are accepted too), feet.",
        &["id", "flyZones"],
        json!({
            "flyZones": fly_zones(
                ["boundaryPoints", "altitudeMin", "altitudeMax"],
                latlon("latitude", "longitude", &[]),
            ),
            "waypoints": {"type": "array", "items": latlon("latitude", "longitude", &[("altitude", feet("Altitude"))])},
            "stationaryObstacles": {"type": "array", "items": latlon("latitude", "longitude", &[
                ("radius", json!({"type": "number", "exclusiveMinimum": 0, "description": "Radius, feet"})),
                ("height", feet("Top")),
            ])},
        }),
    );
    let schemas = &mut doc["components"]["schemas"];
    if !schemas.is_object() {
        return;
    }
    schemas["Interop2018Mission"] = interop_2018;
    schemas["Interop2019Mission"] = interop_2019;
    schemas["Interop2018MissionList"] = json!({
        "type": "array",
        "title": "Interop2018MissionList",
        "description": "Format `interop-2018`: the 2018 `GET /api/missions` list; every mission in it is created, all or none.",
        "minItems": 1,
        "items": {"$ref": "#/components/schemas/Interop2018Mission"},
    });
    let body = &mut doc["paths"]["/api/v1/missions"]["post"]["requestBody"];
    if body.is_object() {
        body["description"] = json!(
            "A mission in one of the accepted formats, detected unless `?format=` names it: `native` (MissionInput), `interop-2018` (one mission or the list) or `interop-2019`"
        );
        body["content"]["application/json"]["schema"] = json!({"oneOf": [
            {"$ref": "#/components/schemas/MissionInput"},
            {"$ref": "#/components/schemas/Interop2018Mission"},
            {"$ref": "#/components/schemas/Interop2018MissionList"},
            {"$ref": "#/components/schemas/Interop2019Mission"},
        ]});
    }
}
