#!/usr/bin/env bash
# Validates deploy/k8s/*.yaml offline: yamllint (syntax and style) and kubernetes-validate (the
# Kubernetes OpenAPI schemas of a release, strict: unknown fields are errors), both from PyPI,
# installed into a virtual environment (VENV, default ~/.cache/gpu-amcs-k8s-venv).
#   K8S_VERSION: the Kubernetes release whose schemas are used (default 1.30.0).
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/gpu-amcs-k8s-venv}"
if [ ! -x "$venv/bin/kubernetes-validate" ] || [ ! -x "$venv/bin/yamllint" ]; then
  echo "== installing kubernetes-validate and yamllint into $venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet kubernetes-validate yamllint
fi
echo "== yamllint"
"$venv/bin/yamllint" -d '{extends: default, rules: {line-length: {max: 100}, document-start: disable}}' \
  deploy/k8s/*.yaml
echo "== kubernetes-validate (Kubernetes ${K8S_VERSION:-1.30.0}, strict)"
"$venv/bin/kubernetes-validate" --strict --kubernetes-version "${K8S_VERSION:-1.30.0}" \
  deploy/k8s/*.yaml
