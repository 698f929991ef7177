// The benchmarks' coherent rays: a side×side pinhole camera grid looking at the mesh from outside
// its box (what mouse picking and visibility tests cast), 8 floats a ray, unit directions.
export function primaryRays(positions, side) {
  const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3) for (let k = 0; k < 3; k++) { min[k] = Math.min(min[k], positions[i + k]); max[k] = Math.max(max[k], positions[i + k]); }
  const c = [0, 1, 2].map((k) => (min[k] + max[k]) / 2);
  const size = Math.max(...[0, 1, 2].map((k) => max[k] - min[k]));
  const eye = [c[0] + 0.3 * size, c[1] + 0.2 * size, c[2] + 1.6 * size];
  const fwd = c.map((x, k) => x - eye[k]); const fl = Math.hypot(...fwd); fwd.forEach((_, k) => { fwd[k] /= fl; });
  const right = [fwd[2], 0, -fwd[0]]; const rl = Math.hypot(...right); right.forEach((_, k) => { right[k] /= rl; });
  const up = [right[1] * fwd[2] - right[2] * fwd[1], right[2] * fwd[0] - right[0] * fwd[2], right[0] * fwd[1] - right[1] * fwd[0]];
  const out = new Float32Array(8 * side * side);
  const h = Math.tan(0.35);
  for (let y = 0; y < side; y++) for (let x = 0; x < side; x++) {
    const sx = ((x + 0.5) / side * 2 - 1) * h, sy = (1 - (y + 0.5) / side * 2) * h;
    const d = [0, 1, 2].map((k) => fwd[k] + sx * right[k] + sy * up[k]);
    const l = Math.hypot(...d);
    out.set([...eye, d[0] / l, d[1] / l, d[2] / l, 0, Infinity], 8 * (y * side + x));
  }
  return out;
}
