// Colours of the control structures (shared by the controls view and the method modules).

import * as THREE from 'three';

export const COL = {
  point: new THREE.Color(0xff8a1f),
  selected: new THREE.Color(0xffe14d),
  frozen: new THREE.Color(0x62c8ff),
  disabled: new THREE.Color(0x7a7a7a),
  curve: new THREE.Color(0xff5fa2),
  skeleton: new THREE.Color(0x48d17a),
  edge: 0x9aa0a8,
  proxy: 0x4f8dff,
  skeletonEdge: 0x3fcf74,
};
// EBF ellipsoids by hierarchy level
const LEVEL_COLORS = [0x58a6ff, 0xb07cff, 0x3fd0b6, 0xffb347, 0xff6b8b, 0xc8e06a];
export const levelColor = (k) => LEVEL_COLORS[((k % LEVEL_COLORS.length) + LEVEL_COLORS.length) % LEVEL_COLORS.length];

