#!/bin/sh
# Rewrites the generated part of docs/CLI.md (every command's --help) from the built program.
# Usage: scripts/update-cli-doc.sh [build-folder]   (default: build)
set -eu
build=${1:-build}
cmake --build "$build" --target apps_cli_test lightskin
LIGHTSKIN_UPDATE_CLI_DOC=1 "$build/tests/apps/apps_cli_test" --gtest_filter='Cli.DocsListEveryCommandAsTheProgramDoes'
