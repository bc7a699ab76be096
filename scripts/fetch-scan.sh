#!/usr/bin/env bash
# Fetches a real public brain MRI for the scan tests and the README into
# data/scans/ (git-ignored; nothing here is committed):
#
#   data/scans/mni152_t1.nii.gz   197 x 233 x 189 voxels, 1 mm, u8, 1.6 MB
#
# It is the skull-stripped T1 of the MNI ICBM152 2009a nonlinear symmetric
# average brain (an average of 152 adult MRI scans), as shipped inside the
# nilearn Python package (file nilearn/datasets/data/
# mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz), taken from the package
# registry with pip (pinned version, checked by SHA-256).
#
# Licence of the scan (the MNI/McGill notice it is distributed under):
#   Copyright (C) 1993-2009 Louis Collins, McConnell Brain Imaging Centre,
#   Montreal Neurological Institute, McGill University. Permission to use,
#   copy, modify, and distribute this software and its documentation for any
#   purpose and without fee is hereby granted, provided that the above
#   copyright notice appear in all copies. The authors and McGill University
#   make no representations about the suitability of this software for any
#   purpose. It is provided "as is" without express or implied warranty.
# The nilearn package that carries it is BSD-3-Clause. References: Fonov et
# al., NeuroImage 47 (2009) S102 and 54(1) (2011) 313-327; Collins et al.,
# NeuroImage (1999).
#
# Usage: scripts/fetch-scan.sh   (needs python3 and pip; about 12 MB downloaded)
# Then: kdcontour compare --volume data/scans/mni152_t1.nii.gz --iso 40
# and the tests that use it run instead of saying it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
version=0.14.1
wheel_sha=725206484e9fb3f6691f9c2d20204a068759d5072f12055324702ee0cb2bbe8a
scan_sha=421a10e872fd6cadae7f61d358dffbcc1795a497d61ee76c5dda2503e1a1e9e6
member=nilearn/datasets/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz
out=data/scans/mni152_t1.nii.gz

if [ -f "$out" ] && echo "$scan_sha  $out" | sha256sum -c --quiet 2>/dev/null; then
    echo "$out is already here"
    exit 0
fi
mkdir -p data/scans
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 -m pip download --quiet --no-deps --only-binary=:all: \
    "nilearn==$version" -d "$tmp"
wheel="$tmp/nilearn-$version-py3-none-any.whl"
echo "$wheel_sha  $wheel" | sha256sum -c --quiet
python3 - "$wheel" "$member" "$tmp/scan" <<'PY'
import sys, zipfile
wheel, member, dest = sys.argv[1:]
with zipfile.ZipFile(wheel) as z, open(dest, "wb") as f:
    f.write(z.read(member))
PY
echo "$scan_sha  $tmp/scan" | sha256sum -c --quiet
mv "$tmp/scan" "$out"
echo "wrote $out (MNI ICBM152 2009a T1, from nilearn $version)"
