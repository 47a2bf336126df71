// Colours of the control structures (shared by the controls view, the method
// modules and the pins of direct manipulation). One colour, one meaning:
// selection is orange (the active point, the last picked, brighter), the
// hovered handle is outlined in white, pins are green / red (reached / not),
// and each method's handles have a colour (and for PB-FFD curves a shape) of
// their own.

import * as THREE from 'three';

export const COL = {
  point: new THREE.Color(0xc4ccd8),       // lattice, T-spline, cage, ... handles at rest
  ebf: new THREE.Color(0x8fc2ff),         // PB-FFD EBF centres (discs)
  selected: new THREE.Color(0xff7a1a),    // selection
  active: new THREE.Color(0xffc46b),      // the active (last picked) point of the selection
  hover: new THREE.Color(0xffffff),       // the ring around the handle under the pointer
  frozen: new THREE.Color(0x62c8ff),
  disabled: new THREE.Color(0x6a6a6a),
  curve: new THREE.Color(0xff5fa2),       // PB-FFD curve points (squares)
  skeleton: new THREE.Color(0x48d17a),
  edge: 0x9aa0a8,
  proxy: 0x4f8dff,
  skeletonEdge: 0x3fcf74,
  // direct manipulation's pins: never the selection's orange
  pin: 0x3fdc8a,
  pinMissed: 0xff4d4d,
  pinSelected: 0xe7f76a,
  // the view's ground grid and axis colours
  gridMajor: 0x4a4f57,
  gridMinor: 0x2e3238,
  axisX: 0xe8505b,
  axisY: 0x7ccf4a,
  axisZ: 0x4f8fe8,
};
// EBF ellipsoids by hierarchy level
const LEVEL_COLORS = [0x58a6ff, 0xb07cff, 0x3fd0b6, 0xffb347, 0xff6b8b, 0xc8e06a];
export const levelColor = (k) => LEVEL_COLORS[((k % LEVEL_COLORS.length) + LEVEL_COLORS.length) % LEVEL_COLORS.length];
