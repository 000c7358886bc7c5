#!/usr/bin/env bash
# Offline checks of the deployment files (no Docker engine, no cluster): the compose file against the
# compose-spec schema, the Kubernetes manifests against the Kubernetes OpenAPI schemas (strict) plus a
# kustomize build, the NATS config with `nats-server -t`, YAML/JSON parsing of the rest, and consistency with
# the code: stream/consumer names from services/scheduler/src/bus.rs, metric names from the scheduler's,
# workers' and adjuster's metrics (deploy/check_consistency.py), probe paths from their routes. Installs its
# own tools when missing. Exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."

failures=0
ok() { printf '  ok    %s\n' "$*"; }
fail() { printf '  FAIL  %s\n' "$*" >&2; failures=$((failures + 1)); }
run() { # run DESCRIPTION CMD...: the command's output is shown only when it fails
    local what="$1" out; shift
    if out="$("$@" 2>&1)"; then ok "$what"; else fail "$what"; printf '%s\n' "$out" | sed 's/^/        /' >&2; fi
}

# --- tools (PyPI, like .ci/run) --------------------------------------------------------------------------
need_pip() { # need_pip COMMAND REQUIREMENT
    command -v "$1" >/dev/null 2>&1 && return 0
    python3 -m pip install --quiet --disable-pip-version-check "$2" >/dev/null
    command -v pyenv >/dev/null 2>&1 && pyenv rehash
    command -v "$1" >/dev/null 2>&1 || export PATH="$(python3 -m site --user-base)/bin:$PATH"
    command -v "$1" >/dev/null 2>&1 || { echo "deploy/check.sh: cannot install $1 ($2)" >&2; exit 1; }
}
need_pip check-jsonschema 'check-jsonschema>=0.29'
need_pip kubernetes-validate 'kubernetes-validate>=1.30'
python3 -c 'import yaml' 2>/dev/null || python3 -m pip install --quiet --disable-pip-version-check PyYAML >/dev/null

echo "deploy/check.sh"

# --- compose ---------------------------------------------------------------------------------------------
run "docker-compose.yml matches the compose-spec schema" \
    check-jsonschema --builtin-schema vendor.compose-spec docker-compose.yml

# --- Kubernetes ------------------------------------------------------------------------------------------
k8s_files=(deploy/k8s/[0-9]*.yaml)
run "deploy/k8s/*.yaml match the Kubernetes schemas (strict)" \
    kubernetes-validate --strict --quiet --no-warn "${k8s_files[@]}"
if command -v kubectl >/dev/null 2>&1; then
    run "kubectl kustomize deploy/k8s builds" kubectl kustomize deploy/k8s
else
    echo "  skip  kubectl kustomize (no kubectl)"
fi

# --- NATS ------------------------------------------------------------------------------------------------
if command -v nats-server >/dev/null 2>&1; then
    # The file reads the roles' passwords from the environment.
    run "deploy/nats.conf is a valid nats-server config" env PLUMBLINE_NATS_SCHEDULER_PASSWORD=x \
        PLUMBLINE_NATS_WORKER_PASSWORD=x PLUMBLINE_NATS_ADJUSTER_PASSWORD=x nats-server -t -c deploy/nats.conf
else
    echo "  skip  nats-server -t (no nats-server; .ci/run installs it)"
fi

# --- everything else, and consistency with the code ------------------------------------------------------
run "YAML/JSON parse; bind mounts exist; names match bus.rs; dashboard metrics exported by the services" \
    python3 deploy/check_consistency.py

if [ "$failures" -gt 0 ]; then
    echo "deploy/check.sh: $failures check(s) failed" >&2
    exit 1
fi
echo "deploy/check.sh: all checks passed"
