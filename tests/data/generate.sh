#!/bin/sh
# Regenerates the bundled simulated frames in tests/data (see README.md for what each shows).
# Usage: tests/data/generate.sh [PALLETCTL]   (default: build/src/palletctl/palletctl)
# The simulator is deterministic: the same palletctl gives the same bytes.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
ctl=${1:-${PALLETCTL:-build/src/palletctl/palletctl}}
# Only the numbered frames of this set are replaced.
rm -f "$here"/[0-9][0-9]_*.depth.png "$here"/[0-9][0-9]_*.intensity.png "$here"/[0-9][0-9]_*.json "$here"/[0-9][0-9]_*.preview.png

sim() { "$ctl" simulate --out "$here" "$@"; }

# Full layers, every pattern family (ifm O3D303-like, 352x264).
sim --name 01_block_600x400_o3d303            --pattern block     --format 600x400 --profile o3d303 --seed 101
sim --name 02_block_400x300_ind_o3d303-small        --pattern block     --format 400x300 --pallet ind --profile o3d303-small --seed 102
sim --name 03_interlock_400x300_o3d303        --pattern interlock --format 400x300 --profile o3d303 --seed 103
sim --name 04_interlock_315x232_o3d303        --pattern interlock --format 315x232 --profile o3d303 --seed 104
sim --name 05_brick_300x200_o3d303-small            --pattern brick     --format 300x200 --profile o3d303-small --seed 105
sim --name 06_pinwheel_315x232_o3d303         --pattern pinwheel  --format 315x232 --profile o3d303 --seed 106
sim --name 07_chimney_315x232_ind_o3d303      --pattern chimney   --format 315x232 --pallet ind --profile o3d303 --seed 107
sim --name 08_mixed_600x400_400x300_o3d303    --pattern mixed     --format 600x400 --format 400x300 --extra-format 300x200 --profile o3d303 --seed 108
# Partial layers as depalletizing leaves them.
sim --name 09_block_315x232_rows_o3d303       --pattern block     --format 315x232 --fill 0.6  --removal rows     --profile o3d303 --seed 109
sim --name 10_block_300x200_columns_o3d303-small    --pattern block     --format 300x200 --fill 0.55 --removal columns  --profile o3d303-small --seed 110
sim --name 11_interlock_315x232_corner_o3d303 --pattern interlock --format 315x232 --fill 0.5  --removal corner   --profile o3d303 --seed 111
sim --name 12_block_300x200_holes_o3d303      --pattern block     --format 300x200 --fill 0.75 --removal holes    --profile o3d303 --seed 112
sim --name 13_block_300x200_clusters_o3d303   --pattern block     --format 300x200 --fill 0.5  --removal clusters --profile o3d303 --seed 113
sim --name 14_brick_315x232_random_o3d303-small     --pattern brick     --format 315x232 --fill 0.4  --removal random   --profile o3d303-small --seed 114
sim --name 15_block_600x400_one_box_o3d303-small    --pattern block     --format 600x400 --fill 0.01 --profile o3d303-small --seed 115
# Binned O3D303 (176x132); 02, 05, 10, 14 and 15 above use it too, to keep the set small.
sim --name 16_block_400x300_few_boxes_o3d303-small --pattern block --format 400x300 --fill 0.25 --removal random --profile o3d303-small --seed 116
sim --name 17_pinwheel_315x232_o3d303-small   --pattern pinwheel  --format 315x232 --profile o3d303-small --seed 117
sim --name 18_chimney_315x232_holes_o3d303-small --pattern chimney --format 315x232 --fill 0.8 --removal holes --profile o3d303-small --seed 118
sim --name 19_block_315x232_nopallet_o3d303-small --pattern block --format 315x232 --pallet none --lower-min 0 --lower-max 0 --profile o3d303-small --seed 119
# The 640x480 profiles.
sim --name 20_interlock_400x300_blaze101      --pattern interlock --format 400x300 --profile blaze101 --seed 120
sim --name 21_pinwheel_315x232_corner_helios2 --pattern pinwheel  --format 315x232 --fill 0.7 --removal corner --profile helios2 --seed 121
sim --name 22_block_600x400_xtion             --pattern block     --format 600x400 --profile xtion --seed 122
