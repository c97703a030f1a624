#!/usr/bin/env bash
# Run the test suite in .venv with DDS isolated to this machine and a domain of its own.
set -euo pipefail
cd "$(dirname "$0")/.."
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
# A domain per run (0..100 keeps the DDS ports in range), unless the caller chose one.
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$(( ($$ + RANDOM) % 90 + 5 ))}
export PYTHONHASHSEED=0 OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} MPLBACKEND=Agg
echo "[test] ROS_DOMAIN_ID=$ROS_DOMAIN_ID ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE"
exec .venv/bin/python -m pytest -q -p no:cacheprovider "$@"
