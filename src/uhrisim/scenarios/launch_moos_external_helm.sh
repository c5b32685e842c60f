#!/usr/bin/env bash
# The MOOS-IvP trail mission in one command, launched as MOOS-IvP missions are: the diver's
# and the ROV's communities (pAntler), the simulation (uhrisim run moos_external_helm.yaml
# --moos) and the helm's deploy (uPokeDB ... MOOS_MANUAL_OVERRIDE=false). Needs MOOS-IvP's
# binaries on PATH (pAntler, MOOSDB, pShare, pContactMgrV20, pHelmIvP, uPokeDB; nsplug to
# regenerate videoray_trail.bhv when meta_videoray_trail.bhv is newer) and uhrisim.
#
#   scenarios/launch_moos_external_helm.sh [uhrisim run options, e.g. --duration 180 -o out/moos]
#
# The MOOS apps' output goes to a temporary folder (printed); everything started here is
# stopped when uhrisim ends or on Ctrl-C. docs/bridges-moos.md explains each part.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
uhrisim=${UHRISIM:-uhrisim}
for app in pAntler MOOSDB pShare pContactMgrV20 pHelmIvP uPokeDB; do
  command -v "$app" >/dev/null || { echo "error: $app is not on PATH (MOOS-IvP's bin folders)" >&2; exit 2; }
done
command -v "$uhrisim" >/dev/null || { echo "error: $uhrisim is not on PATH (set UHRISIM)" >&2; exit 2; }

# pHelmIvP reads videoray_trail.bhv as it stands (it does not run nsplug): regenerate it
# from the meta file after an edit, as a MOOS-IvP launch script does
if [ "$here/meta_videoray_trail.bhv" -nt "$here/videoray_trail.bhv" ]; then
  command -v nsplug >/dev/null || { echo "error: meta_videoray_trail.bhv was edited; nsplug is needed to expand it" >&2; exit 2; }
  (cd "$here" && nsplug meta_videoray_trail.bhv videoray_trail.bhv -f >/dev/null)
fi

logs=$(mktemp -d -t uhrisim-moos-XXXXXX)
echo "MOOS apps' output: $logs"
groups=()
stop() {
  for group in "${groups[@]}"; do kill -INT -- "-$group" 2>/dev/null || true; done
  sleep 1
  for group in "${groups[@]}"; do kill -KILL -- "-$group" 2>/dev/null || true; done
}
trap stop EXIT
trap 'exit 130' INT TERM

for community in diver videoray; do  # each in its own process group, from this folder
  (cd "$here" && exec setsid pAntler "moos_external_helm_$community.moos") \
    >"$logs/$community.log" 2>&1 &
  groups+=("$!")
done

"$uhrisim" run "$here/moos_external_helm.yaml" --moos "$@" &
sim=$!
# deploy the parked helm: the DB keeps the value for pHelmIvP, however soon it starts
until (cd "$here" && timeout 10 uPokeDB moos_external_helm_videoray.moos \
         MOOS_MANUAL_OVERRIDE=false >"$logs/uPokeDB.log" 2>&1); do
  kill -0 "$sim" 2>/dev/null || break
  sleep 1
done
wait "$sim"
