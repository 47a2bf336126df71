// The editor's method registry: one module per deformation method (its
// creation form, its panel section, how its controls are drawn, its pick
// tools). The rest of the page looks the method up here and never names one.
// Adding a method: its module in this folder and one line below.

import lattice from './lattice.js';
import pbffd from './pbffd.js';
import gffd from './gffd.js';
import tspline from './tspline.js';
import cage from './cage.js';
import kelvinlet from './kelvinlet.js';
import rbf from './rbf.js';
import idw from './idw.js';

export const METHODS = [lattice, pbffd, gffd, tspline, cage, kelvinlet, rbf, idw];

/** What a method module may leave out, and the page without a deformer. */
const DEFAULTS = {
  name: '',
  label: '',
  form: {},
  createFields: () => [],
  createBody: () => ({}),
  section: null,
  status: () => '',
  dragBody: () => {},
  rigidDrags: false, // true: a whole-selection move is sent as its motion (delta), not per-control moves (transform.js)
  tools: {},
  busy: {},
  view: {},
};

const byName = new Map(METHODS.map((m) => [m.name, { ...DEFAULTS, ...m, view: { ...(m.view || {}) } }]));
const none = { ...DEFAULTS };

/** The method called name (the state's "method"), or the empty method. */
export function methodOf(name) { return byName.get(name) || none; }

/** Every method's pick tools (click on the mesh), by tool name. */
export const PICK_TOOLS = Object.assign({}, ...METHODS.map((m) => m.tools || {}));

/** The busy overlay's text for the methods' own operations, by op. */
export const BUSY = Object.assign({}, ...METHODS.map((m) => m.busy || {}));
