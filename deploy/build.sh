#!/usr/bin/env bash
# Installs squall's dependencies (deploy/install-deps.sh) and the deployment tools its tests use
# (deploy/install-deploy-tools.sh), then configures and builds into ./build.
# Usage: deploy/build.sh [extra cmake configure arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/install-deploy-tools.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j "$(nproc)"
