//! A small JSON Schema (2020-12) checker covering the keywords schemars emits for the manifest.
//! Any other keyword fails loudly, so a schema that grows a new keyword cannot go unchecked.

use serde_json::Value;

/// Keywords that only annotate, and `pattern`, which needs a regex engine (the one pattern, the
/// campaign id's, is enforced and tested by `CampaignId` itself).
const NOT_CHECKED: &[&str] = &["$schema", "$defs", "title", "description", "default", "format", "pattern"];

/// The places where `instance` breaks `schema`, as "path: reason" lines; empty when it conforms.
pub fn violations(schema: &Value, instance: &Value) -> Vec<String> {
    let mut walker = Walker { root: schema, found: Vec::new() };
    walker.check(schema, instance, "");
    walker.found
}

struct Walker<'a> {
    root: &'a Value,
    found: Vec<String>,
}

impl<'a> Walker<'a> {
    fn check(&mut self, schema: &'a Value, value: &Value, path: &str) {
        let Some(keywords) = schema.as_object() else {
            return self.expect(schema.as_bool() != Some(false), path, "is not allowed here".into());
        };
        for (keyword, rule) in keywords {
            self.keyword(keyword, rule, schema, value, path);
        }
    }

    fn keyword(&mut self, keyword: &str, rule: &'a Value, schema: &'a Value, value: &Value, path: &str) {
        match keyword {
            k if NOT_CHECKED.contains(&k) => {}
            "$ref" => {
                let target = rule.as_str().and_then(|r| r.strip_prefix('#')).and_then(|p| self.root.pointer(p));
                match target {
                    Some(target) => self.check(target, value, path),
                    None => panic!("unresolvable $ref {rule}"),
                }
            }
            "type" => self.expect(type_matches(rule, value), path, format!("is not of type {rule}")),
            "const" => self.expect(rule == value, path, format!("is not {rule}")),
            "enum" => {
                self.expect(rule.as_array().is_some_and(|a| a.contains(value)), path, format!("is not one of {rule}"))
            }
            "minimum" => self.expect(compare(value, rule, |v, r| v >= r), path, format!("is below {rule}")),
            "maximum" => self.expect(compare(value, rule, |v, r| v <= r), path, format!("is above {rule}")),
            "minItems" => self.expect(length(value, rule, |n, r| n >= r), path, format!("has fewer than {rule} items")),
            "maxItems" => self.expect(length(value, rule, |n, r| n <= r), path, format!("has more than {rule} items")),
            "items" => self.items(rule, value, path),
            "required" => self.required(rule, value, path),
            "properties" => self.properties(rule, value, path),
            "additionalProperties" => self.additional(rule, schema, value, path),
            "oneOf" => self.branches(rule, value, path, |n| n == 1, "exactly one"),
            "anyOf" => self.branches(rule, value, path, |n| n >= 1, "at least one"),
            other => panic!("the schema uses keyword {other:?}, which this checker does not know; teach it"),
        }
    }

    fn expect(&mut self, ok: bool, path: &str, reason: String) {
        if !ok {
            self.found.push(format!("{}: {reason}", if path.is_empty() { "/" } else { path }));
        }
    }

    fn items(&mut self, rule: &'a Value, value: &Value, path: &str) {
        for (i, item) in value.as_array().into_iter().flatten().enumerate() {
            self.check(rule, item, &format!("{path}/{i}"));
        }
    }

    fn required(&mut self, rule: &Value, value: &Value, path: &str) {
        let Some(object) = value.as_object() else { return };
        for name in rule.as_array().into_iter().flatten().filter_map(Value::as_str) {
            self.expect(object.contains_key(name), path, format!("lacks required property {name:?}"));
        }
    }

    fn properties(&mut self, rule: &'a Value, value: &Value, path: &str) {
        let (Some(rules), Some(object)) = (rule.as_object(), value.as_object()) else { return };
        for (name, item) in object {
            if let Some(rule) = rules.get(name) {
                self.check(rule, item, &format!("{path}/{name}"));
            }
        }
    }

    fn additional(&mut self, rule: &'a Value, schema: &Value, value: &Value, path: &str) {
        let Some(object) = value.as_object() else { return };
        let declared = schema.get("properties").and_then(Value::as_object);
        for (name, item) in object.iter().filter(|(n, _)| !declared.is_some_and(|d| d.contains_key(*n))) {
            self.check(rule, item, &format!("{path}/{name}"));
        }
    }

    fn branches(&mut self, rule: &'a Value, value: &Value, path: &str, ok: fn(usize) -> bool, wanted: &str) {
        let outcomes: Vec<Vec<String>> =
            rule.as_array().into_iter().flatten().map(|b| self.trial(b, value, path)).collect();
        let passed = outcomes.iter().filter(|o| o.is_empty()).count();
        let detail = outcomes.concat().join("; ");
        self.expect(ok(passed), path, format!("matches {passed} branches, not {wanted} ({detail})"));
    }

    fn trial(&self, schema: &'a Value, value: &Value, path: &str) -> Vec<String> {
        let mut walker = Walker { root: self.root, found: Vec::new() };
        walker.check(schema, value, path);
        walker.found
    }
}

fn type_matches(rule: &Value, value: &Value) -> bool {
    let is = |name: &str| match name {
        "null" => value.is_null(),
        "boolean" => value.is_boolean(),
        "object" => value.is_object(),
        "array" => value.is_array(),
        "string" => value.is_string(),
        "number" => value.is_number(),
        "integer" => value.is_i64() || value.is_u64(),
        other => panic!("unknown type {other:?}"),
    };
    match rule {
        Value::String(name) => is(name),
        Value::Array(names) => names.iter().filter_map(Value::as_str).any(is),
        other => panic!("malformed type {other}"),
    }
}

fn compare(value: &Value, rule: &Value, ok: fn(f64, f64) -> bool) -> bool {
    match (value.as_f64(), rule.as_f64()) {
        (Some(v), Some(r)) => ok(v, r),
        _ => true,
    }
}

fn length(value: &Value, rule: &Value, ok: fn(u64, u64) -> bool) -> bool {
    match (value.as_array(), rule.as_u64()) {
        (Some(items), Some(r)) => ok(items.len() as u64, r),
        _ => true,
    }
}
