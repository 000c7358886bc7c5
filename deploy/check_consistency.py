"""Offline consistency checks of the deployment files against each other and against the code (run by
deploy/check.sh): every YAML/JSON/TOML file parses; compose bind mounts exist; the `plumbline serve <role>`
flags used in compose and k8s exist in services/cli/src/serve.rs; the KEDA trigger names the stream and
consumer of services/scheduler/src/bus.rs; every plumbline_* metric the dashboard and docs query is one
services/scheduler/src/service/metrics.rs, services/worker/src/service/probe.rs or
services/adjuster/src/service/probe.rs exports; probe paths are routes of the scheduler or of the ops listener; example tokens
satisfy the scheduler's rules. Prints each problem and exits 1 if there is any."""

import json
import pathlib
import re
import sys
import tomllib

import yaml

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEPLOY = ROOT / "deploy"
problems = []


def problem(msg):
    problems.append(msg)


def read(rel):
    return (ROOT / rel).read_text()


def load_yaml_all(path):
    try:
        return [d for d in yaml.safe_load_all(path.read_text()) if d is not None]
    except yaml.YAMLError as e:
        problem(f"{path.relative_to(ROOT)}: YAML: {e}")
        return []


def rust_const(src, name):
    m = re.search(rf'pub const {name}: &str = "([^"]+)";', src)
    if not m:
        problem(f"services/scheduler/src/bus.rs: const {name} not found")
        return None
    return m.group(1)


def role_flags():
    """{role: set of long flags} of `plumbline serve`, from the clap structs in serve.rs."""
    src = read("services/cli/src/serve.rs")
    structs = {}
    for name, body in re.findall(r"pub struct (\w+) \{(.*?)\n\}", src, re.S):
        flags, flatten = set(), []
        for attrs, field, ty in re.findall(r"((?:\s*#\[[^\n]*\]\n)*)\s*pub (\w+): ([\w<>]+),", body):
            if "command(flatten)" in attrs:
                flatten.append(ty)
            elif "arg(long" in attrs:
                flags.add("--" + field.replace("_", "-"))
        structs[name] = (flags, flatten)

    def resolve(name):
        flags, flatten = structs.get(name, (set(), []))
        out = set(flags)
        for inner in flatten:
            out |= resolve(inner)
        return out

    roles = re.findall(r"^\s*(\w+)\((\w+)\),", src.split("pub enum Command", 1)[1].split("}", 1)[0], re.M)
    return {variant.lower(): resolve(args) for variant, args in roles}


def check_serve_args(where, args, roles):
    if len(args) < 2 or args[0] != "serve":
        problem(f"{where}: expected `serve <role> ...`, got {args}")
        return
    role = args[1]
    if role not in roles:
        problem(f"{where}: `plumbline serve {role}` does not exist (serve.rs has {sorted(roles)})")
        return
    for a in args[2:]:
        if a.startswith("--") and a.split("=", 1)[0] not in roles[role]:
            problem(f"{where}: serve {role} has no flag {a} (it has {sorted(roles[role])})")


def check_compose(roles):
    docs = load_yaml_all(ROOT / "docker-compose.yml")
    if not docs:
        return {}
    compose = docs[0]
    for name, svc in compose.get("services", {}).items():
        for vol in svc.get("volumes", []):
            src = vol.split(":", 1)[0] if isinstance(vol, str) else vol.get("source", "")
            if src.startswith("."):
                if not (ROOT / src).exists():
                    problem(f"docker-compose.yml: services.{name}.volumes: {src} does not exist")
        if svc.get("image", "").startswith("plumbline"):
            check_serve_args(f"docker-compose.yml: services.{name}.command", svc.get("command", []), roles)
    return compose


def check_k8s(roles, bus):
    deployments, objects = {}, []
    for path in sorted((DEPLOY / "k8s").glob("*.yaml")):
        for doc in load_yaml_all(path):
            objects.append((path.name, doc))
            if doc.get("kind") == "Deployment":
                deployments[doc["metadata"]["name"]] = doc
    routes = read("services/scheduler/src/service/routes.rs")
    ops_routes = read("services/runtime/src/ops/server.rs")
    for name, dep in deployments.items():
        for c in dep["spec"]["template"]["spec"]["containers"]:
            if c.get("image") == "plumbline":
                check_serve_args(f"deploy/k8s: {name}", c.get("args", []), roles)
            args = c.get("args", [])
            role = args[1] if len(args) > 1 else ""
            for probe in ("livenessProbe", "readinessProbe"):
                path = c.get(probe, {}).get("httpGet", {}).get("path")
                if not path or c.get("image") != "plumbline":
                    continue
                if role == "scheduler" and f'.route("{path}"' not in routes:
                    problem(f"deploy/k8s: {name} {probe} path {path} is not a scheduler route")
                if role in ("worker", "adjuster"):
                    if f'"{path}" =>' not in ops_routes:
                        problem(f"deploy/k8s: {name} {probe} path {path} is not an ops route (worker/service/ops.rs)")
                    if "--ops-listen" not in args:
                        problem(f"deploy/k8s: {name} has a {probe} but no --ops-listen")
    scaled = [d for _, d in objects if d.get("kind") == "ScaledObject"]
    if len(scaled) != 1:
        problem(f"deploy/k8s: expected one ScaledObject, found {len(scaled)}")
    for so in scaled:
        target = so["spec"]["scaleTargetRef"]["name"]
        if target not in deployments:
            problem(f"deploy/k8s: ScaledObject targets {target}, not a Deployment here")
        for t in so["spec"]["triggers"]:
            md = t["metadata"]
            if t["type"] != "nats-jetstream":
                problem(f"deploy/k8s: ScaledObject trigger type {t['type']}")
            if md.get("stream") != bus["TASKS_STREAM"] or md.get("consumer") != bus["WORKERS_CONSUMER"]:
                problem(f"deploy/k8s: ScaledObject watches {md.get('stream')}/{md.get('consumer')}, bus.rs says "
                        f"{bus['TASKS_STREAM']}/{bus['WORKERS_CONSUMER']}")
            if not md.get("natsServerMonitoringEndpoint", "").endswith(":8222"):
                problem("deploy/k8s: ScaledObject natsServerMonitoringEndpoint is not the NATS monitor port 8222")
    nats_conf = [d for _, d in objects if d.get("kind") == "ConfigMap" and d["metadata"]["name"] == "nats-config"]
    if not nats_conf or "http_port: 8222" not in nats_conf[0]["data"]["nats.conf"]:
        problem("deploy/k8s: nats-config does not enable the monitoring port 8222 (KEDA reads /jsz there)")
    compose_conf = (DEPLOY / "nats.conf").read_text()
    if "http_port: 8222" not in compose_conf:
        problem("deploy/nats.conf: monitoring port 8222 not enabled")
    check_nats_users(compose_conf, nats_conf[0]["data"]["nats.conf"] if nats_conf else "", deployments)


def check_nats_users(compose_conf, k8s_conf, deployments):
    """deploy/nats.conf and the k8s nats-config have the same users and permissions (the system test runs on
    the first); every role connects as its user, in compose and k8s, and NATS's client port is not published."""
    def auth(text):
        return text[text.find("authorization {"):].strip() if "authorization {" in text else ""
    if not auth(compose_conf):
        problem("deploy/nats.conf: no authorization block")
    if auth(compose_conf) != auth(k8s_conf):
        problem("deploy/k8s/20-nats.yaml: the nats-config authorization block differs from deploy/nats.conf's")
    for name, dep in deployments.items():
        for c in dep["spec"]["template"]["spec"]["containers"]:
            args = c.get("args", [])
            if c.get("image") != "plumbline" or len(args) < 2:
                continue
            env = {e["name"]: e for e in c.get("env", [])}
            if env.get("PLUMBLINE_NATS_USER", {}).get("value") != args[1]:
                problem(f"deploy/k8s: {name} does not connect to NATS as user {args[1]}")
            if "PLUMBLINE_NATS_PASSWORD" not in env:
                problem(f"deploy/k8s: {name} has no PLUMBLINE_NATS_PASSWORD")
    compose = yaml.safe_load(read("docker-compose.yml"))
    for name, svc in compose["services"].items():
        command = svc.get("command", [])
        if len(command) > 1 and command[0] == "serve":
            env = svc.get("environment", {})
            if env.get("PLUMBLINE_NATS_USER") != command[1] or not env.get("PLUMBLINE_NATS_PASSWORD"):
                problem(f"docker-compose.yml: {name} does not connect to NATS as user {command[1]} with a password")
            var = f"PLUMBLINE_NATS_{command[1].upper()}_PASSWORD"
            if compose["services"]["nats"].get("environment", {}).get(var) != env.get("PLUMBLINE_NATS_PASSWORD"):
                problem(f"docker-compose.yml: {name}'s NATS password is not the server's {var}")
    for port in compose["services"]["nats"].get("ports", []):
        if "4222" in str(port):
            problem("docker-compose.yml: the NATS client port 4222 is published on the host")


METRIC_SOURCES = {
    # file: families written with header(&mut out, "name", ...) (scheduler) or declared as
    # ("name", Kind::…, "help") (worker and adjuster registries; a summary exports name_sum and name_count)
    "services/scheduler/src/service/metrics.rs": "header",
    "services/worker/src/service/probe.rs": "family",
    "services/adjuster/src/service/probe.rs": "family",
}


def exported_metrics():
    names = set()
    for rel, style in METRIC_SOURCES.items():
        src = read(rel)
        if style == "header":
            found = set(re.findall(r'header\(&mut out, "(plumbline_\w+)"', src))
        else:
            found = set()
            for name, kind in re.findall(r'\(\s*"(plumbline_\w+)",\s*Kind::(\w+)', src):
                found.add(name)
                if kind == "Summary":
                    found |= {name + "_sum", name + "_count"}
        if not found:
            problem(f"{rel}: no metric families found")
        names |= found
    return names


def check_dashboard(metrics, compose):
    path = DEPLOY / "grafana/dashboards/plumbline.json"
    try:
        dash = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        problem(f"{path.relative_to(ROOT)}: JSON: {e}")
        return
    ds = load_yaml_all(DEPLOY / "grafana/provisioning/datasources/datasources.yaml")
    uids = {d["uid"] for doc in ds for d in doc.get("datasources", [])}
    ids = [p["id"] for p in dash.get("panels", [])]
    if len(ids) != len(set(ids)):
        problem("plumbline.json: duplicate panel ids")
    prom = load_yaml_all(DEPLOY / "prometheus.yml")
    jobs = {j["job_name"] for doc in prom for j in doc.get("scrape_configs", [])}
    for p in dash.get("panels", []):
        for t in p.get("targets", []):
            if t.get("datasource", {}).get("uid") not in uids:
                problem(f"plumbline.json: panel {p['title']!r} uses an unprovisioned datasource")
            expr = t.get("expr", "")
            for m in re.findall(r"\bplumbline_\w+", expr):
                if m not in metrics:
                    problem(f"plumbline.json: panel {p['title']!r} queries {m}, which no service exports")
            for job in re.findall(r'job="([^"]+)"', expr):
                if job not in jobs:
                    problem(f"plumbline.json: panel {p['title']!r} uses job {job}, not in deploy/prometheus.yml")
    sched = compose.get("services", {}).get("scheduler", {})
    listen = next((a for a in sched.get("command", []) if re.match(r"[\d.]+:\d+$", str(a))), None)
    targets = [t for doc in prom for j in doc.get("scrape_configs", []) if j["job_name"] == "plumbline-scheduler"
               for sc in j.get("static_configs", []) for t in sc.get("targets", [])]
    if listen and f"scheduler:{listen.rsplit(':', 1)[1]}" not in targets:
        problem(f"deploy/prometheus.yml: scheduler target {targets} does not match --listen {listen}")


def check_tokens():
    min_len = int(re.search(r"MIN_TOKEN_LEN: usize = (\d+)", read("services/scheduler/src/service/auth.rs")).group(1))
    tokens = tomllib.loads((DEPLOY / "tokens.example.toml").read_text()).get("tokens", {})
    if not tokens:
        problem("deploy/tokens.example.toml: empty [tokens]")
    for i, (token, agency) in enumerate(tokens.items()):
        if len(token) < min_len:
            problem(f"deploy/tokens.example.toml: token #{i + 1} shorter than {min_len}")
        if not re.fullmatch(r"[a-z0-9][a-z0-9_-]*", agency):
            problem(f"deploy/tokens.example.toml: agency {agency!r} breaks the campaign-id rules")
    demo = (DEPLOY / "demo-token.example.txt").read_text().strip()
    if demo not in tokens:
        problem("deploy/demo-token.example.txt: not a token of deploy/tokens.example.toml")


def main():
    for path in sorted(DEPLOY.rglob("*.y*ml")):
        load_yaml_all(path)
    bus_src = read("services/scheduler/src/bus.rs")
    bus = {n: rust_const(bus_src, n) for n in ("TASKS_STREAM", "WORKERS_CONSUMER")}
    roles = role_flags()
    if "scheduler" not in roles:
        problem("services/cli/src/serve.rs: no `serve scheduler` role found")
    compose = check_compose(roles)
    check_k8s(roles, bus)
    check_dashboard(exported_metrics(), compose)
    check_tokens()
    for p in problems:
        print(p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
