//! The committed `openapi/openapi.json` must be exactly what the code generates.

#[test]
fn the_committed_openapi_document_matches_the_code() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../openapi/openapi.json");
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    let generated = server::openapi_json();
    assert!(
        committed == generated,
        "openapi/openapi.json is out of date with the code.\nRegenerate it with:\n    cargo run -p server -- openapi > openapi/openapi.json\nand commit the result."
    );
}

#[test]
fn the_risk_look_ahead_is_documented_up_to_the_live_maps_horizon() {
    // A documented maximum above the horizon makes schema-valid requests answer 422.
    let doc: serde_json::Value = serde_json::from_str(&server::openapi_json()).unwrap();
    let mut seen = 0;
    for (path, ops) in doc["paths"].as_object().unwrap() {
        for op in ops.as_object().unwrap().values() {
            for p in op["parameters"].as_array().into_iter().flatten() {
                if p["name"] == "t" && p["in"] == "query" {
                    assert_eq!(
                        p["schema"]["maximum"].as_f64(),
                        Some(planner::DEFAULT_HORIZON_S),
                        "{path}"
                    );
                    seen += 1;
                }
            }
        }
    }
    assert!(seen >= 3, "{seen} look-ahead parameters found");
}

#[test]
fn every_response_has_a_description() {
    let doc: serde_json::Value = serde_json::from_str(&server::openapi_json()).unwrap();
    for (path, ops) in doc["paths"].as_object().unwrap() {
        for (method, op) in ops.as_object().unwrap() {
            let Some(responses) = op.get("responses").and_then(|r| r.as_object()) else {
                continue;
            };
            assert!(
                !responses.is_empty(),
                "{method} {path} documents no response"
            );
            for (status, r) in responses {
                let d = r["description"].as_str().unwrap_or("");
                assert!(!d.is_empty(), "{method} {path} {status} has no description");
            }
        }
    }
}

fn collect_refs(v: &serde_json::Value, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            if let Some(r) = m.get("$ref").and_then(|r| r.as_str()) {
                out.push(r.to_string());
            }
            m.values().for_each(|x| collect_refs(x, out));
        }
        serde_json::Value::Array(a) => a.iter().for_each(|x| collect_refs(x, out)),
        _ => {}
    }
}

#[test]
fn every_reference_resolves_to_a_defined_schema() {
    let doc: serde_json::Value = serde_json::from_str(&server::openapi_json()).unwrap();
    let mut refs = Vec::new();
    collect_refs(&doc, &mut refs);
    assert!(refs.len() > 20, "only {} references found", refs.len());
    for r in refs {
        let name = r
            .strip_prefix("#/components/schemas/")
            .unwrap_or_else(|| panic!("{r} is not a schema reference"));
        assert!(
            doc["components"]["schemas"].get(name).is_some(),
            "{r} is referenced but not defined"
        );
    }
}

#[test]
fn query_and_body_errors_and_missing_missions_are_documented() {
    let doc: serde_json::Value = serde_json::from_str(&server::openapi_json()).unwrap();
    let ops = [
        ("/api/v1/missions/{id}/observations", "get", ["400", "404"]),
        ("/api/v1/missions/{id}/telemetry", "get", ["400", "404"]),
        ("/api/v1/missions/{id}/telemetry", "post", ["413", "422"]),
        ("/api/v1/missions", "post", ["413", "415"]),
    ];
    for (path, method, statuses) in ops {
        for s in statuses {
            let r = &doc["paths"][path][method]["responses"][s];
            assert_eq!(
                r["content"]["application/problem+json"]["schema"]["$ref"],
                "#/components/schemas/Problem",
                "{method} {path} does not document {s} with the problem schema"
            );
        }
    }
}

#[test]
fn mission_is_one_flat_object_with_a_required_home() {
    let doc: serde_json::Value = serde_json::from_str(&server::openapi_json()).unwrap();
    let m = &doc["components"]["schemas"]["Mission"];
    assert_eq!(m["type"], "object");
    assert!(m.get("allOf").is_none());
    assert_eq!(m["properties"]["home"]["$ref"], "#/components/schemas/Home");
    let required: Vec<&str> = m["required"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|v| v.as_str())
        .collect();
    for name in ["id", "home", "fly_zones", "source_format"] {
        assert!(
            required.contains(&name),
            "{name} not required: {required:?}"
        );
    }
}

#[test]
fn creating_a_mission_links_to_its_scoped_operations() {
    let doc: serde_json::Value = serde_json::from_str(&server::openapi_json()).unwrap();
    let links = &doc["paths"]["/api/v1/missions"]["post"]["responses"]["201"]["links"];
    for op in [
        "get_mission",
        "post_obstacles",
        "post_telemetry",
        "create_plan",
        "get_risk",
    ] {
        assert_eq!(links[op]["operationId"], op);
        assert_eq!(links[op]["parameters"]["id"], "$response.body#/id");
    }
}
