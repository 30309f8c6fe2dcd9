// Whipping 1000:1 chain: what to do in a substep where SHAKE fails.
// 100 links of 1 cm (1 m), unit masses, tip 1000x, pinned at one end, released horizontal,
// g = 9.81, 1/64 s steps x 8 substeps, no damping, 5 s. SHAKE as the crate runs it: start-of-
// substep directions, warm start from the last substep's multipliers, Newton passes (Thomas)
// until max |C|/L <= 1e-9, at most 3 passes and each must divide the error by 10, skipped when a
// link's predicted turn has cosine < 0.99 or in the substep after a failure. Fallbacks compared:
//   project : Newton on the position projection (current directions) from the prediction, as the
//             crate does (up to 32 passes);
//   halve   : the substep re-run as two half substeps, each with SHAKE (their own fallback: the
//             projection), the Verlet state converted to h/2 and back.
// Prints Newton passes, substeps by kind, the largest link strain and the energy lost of what
// the fall released.  gcc -O2 whip_substep.c -lm && ./a.out
#include <math.h>
#include <stdio.h>
#include <string.h>
#define N 100
typedef struct { double x, y; } V;
static V x[N + 1], xp[N + 1], r[N];
static double w[N + 1], lam[N], warm[N];
static const double L = 0.01, G = 9.81, TOL = 1e-9;
static long passes, shake_ok, shake_failed, projected, halved;

static double energy(double h) {
  double e = 0;
  for (int i = 1; i <= N; i++) {
    double m = 1 / w[i], vx = (x[i].x - xp[i].x) / h, vy = (x[i].y - xp[i].y) / h;
    e += m * (0.5 * (vx * vx + vy * vy) + G * 0.5 * (x[i].y + xp[i].y));
  }
  return e;
}
static double err(void) {
  double e = 0;
  for (int i = 0; i < N; i++) {
    double d = hypot(x[i + 1].x - x[i].x, x[i + 1].y - x[i].y);
    e = fmax(e, fabs(d - L) / L);
  }
  return e;
}
static void move(int k, double d, V dir) { // stick k's multiplier by d along dir
  lam[k] += d;
  if (w[k] > 0) { x[k].x -= w[k] * dir.x * d; x[k].y -= w[k] * dir.y * d; }
  x[k + 1].x += w[k + 1] * dir.x * d; x[k + 1].y += w[k + 1] * dir.y * d;
}
// One Newton pass; shake: correction along r (start directions), else along current normals.
static void pass(int shake) {
  static V n[N], dir[N];
  static double a[N], b[N], c[N], rhs[N], d[N];
  for (int i = 0; i < N; i++) {
    double dx = x[i + 1].x - x[i].x, dy = x[i + 1].y - x[i].y, len = hypot(dx, dy);
    n[i] = (V){dx / len, dy / len};
    dir[i] = shake ? r[i] : n[i];
    rhs[i] = -(len - L);
  }
  for (int i = 0; i < N; i++) {
    b[i] = (w[i] + w[i + 1]) * (n[i].x * dir[i].x + n[i].y * dir[i].y) * (1 + 1e-9);
    a[i] = i > 0 ? -w[i] * (n[i].x * dir[i - 1].x + n[i].y * dir[i - 1].y) : 0;
    c[i] = i < N - 1 ? -w[i + 1] * (n[i].x * dir[i + 1].x + n[i].y * dir[i + 1].y) : 0;
  }
  for (int i = 1; i < N; i++) {
    double m = a[i] / b[i - 1];
    b[i] -= m * c[i - 1];
    rhs[i] -= m * rhs[i - 1];
  }
  d[N - 1] = rhs[N - 1] / b[N - 1];
  for (int i = N - 2; i >= 0; i--) d[i] = (rhs[i] - c[i] * d[i + 1]) / b[i];
  // Positions move linearly in d along dir: apply all at once.
  V moveby[N + 1];
  memset(moveby, 0, sizeof moveby);
  for (int i = 0; i < N; i++) {
    lam[i] += d[i];
    moveby[i].x -= dir[i].x * d[i]; moveby[i].y -= dir[i].y * d[i];
    moveby[i + 1].x += dir[i].x * d[i]; moveby[i + 1].y += dir[i].y * d[i];
  }
  for (int j = 0; j <= N; j++) { x[j].x += w[j] * moveby[j].x; x[j].y += w[j] * moveby[j].y; }
  passes++;
}
static void predict(double h, double damp) {
  (void)damp;
  for (int i = 0; i <= N; i++) {
    if (w[i] == 0) { xp[i] = x[i]; continue; }
    V v = {x[i].x - xp[i].x, x[i].y - xp[i].y};
    xp[i] = x[i];
    x[i].x += v.x;
    x[i].y += v.y - G * h * h;
  }
}
// SHAKE with warm start (scaled): returns 1 if converged.
static int shake(double warm_scale) {
  for (int i = 0; i < N; i++) {
    double dx = xp[i + 1].x - xp[i].x, dy = xp[i + 1].y - xp[i].y, l = hypot(dx, dy);
    r[i] = (V){dx / l, dy / l};
    double cx = x[i + 1].x - x[i].x, cy = x[i + 1].y - x[i].y;
    if (r[i].x * cx + r[i].y * cy < 0.99 * hypot(cx, cy)) return -1; // turns too far
  }
  V save[N + 1];
  memcpy(save, x, sizeof save);
  double before_warm = err();
  memset(lam, 0, sizeof lam);
  for (int i = 0; i < N; i++) move(i, warm[i] * warm_scale, r[i]);
  double e = err();
  if (e > before_warm) { memcpy(x, save, sizeof save); memset(lam, 0, sizeof lam); e = before_warm; }
  double prev = INFINITY;
  for (int k = 0; ; k++) {
    if (e <= TOL) return 1;
    if (k == 3 || e > 0.1 * prev) { memcpy(x, save, sizeof save); return 0; }
    prev = e;
    pass(1);
    e = err();
  }
}
static void project(void) {
  memset(lam, 0, sizeof lam);
  for (int k = 0; k < 32 && err() > TOL; k++) pass(0);
}
static int fell_back;
// One substep of length h; mode 0: project on failure, 1: halve on failure.
static void substep(double h, int mode, int depth) {
  V x0[N + 1], xp0[N + 1];
  memcpy(x0, x, sizeof x0);
  memcpy(xp0, xp, sizeof xp0);
  predict(h, 0);
  int ok = fell_back && depth == 0 ? -1 : shake(depth ? 0.25 : 1.0);
  if (ok == 1) { shake_ok++; fell_back = 0; memcpy(warm, lam, sizeof warm); return; }
  if (ok == 0) shake_failed++;
  if (mode == 1 && depth == 0 && ok != -2) {
    // Two half substeps from the start state, the Verlet velocity kept.
    memcpy(x, x0, sizeof x0);
    for (int i = 0; i <= N; i++) { xp[i].x = x0[i].x - 0.5 * (x0[i].x - xp0[i].x); xp[i].y = x0[i].y - 0.5 * (x0[i].y - xp0[i].y); }
    halved++;
    substep(h / 2, mode, 1);
    V mid[N + 1];
    memcpy(mid, x, sizeof mid);
    substep(h / 2, mode, 1);
    for (int i = 0; i <= N; i++) { xp[i].x = x[i].x - 2 * (x[i].x - mid[i].x); xp[i].y = x[i].y - 2 * (x[i].y - mid[i].y); }
    memcpy(warm, lam, sizeof warm);
    for (int i = 0; i < N; i++) warm[i] *= 4;
    fell_back = 0;
    return;
  }
  projected++;
  project();
  memcpy(warm, lam, sizeof warm);
  if (depth == 0) fell_back = (ok == 0);
}
int main(void) {
  const double h = 1.0 / 64 / 8;
  for (int mode = 0; mode < 2; mode++) {
    for (int i = 0; i <= N; i++) { x[i] = (V){i * L, 0}; xp[i] = x[i]; w[i] = 1; }
    w[0] = 0; w[N] = 1.0 / 1000;
    memset(warm, 0, sizeof warm);
    passes = shake_ok = shake_failed = projected = halved = 0; fell_back = 0;
    double e0 = energy(h), floor = 0, strain = 0;
    for (int i = 1; i <= N; i++) floor -= G * (i * L) / w[i]; // hanging straight down
    for (int s = 0; s < 64 * 5 * 8; s++) {
      substep(h, mode, 0);
      strain = fmax(strain, err());
    }
    double e = energy(h);
    printf("%-8s passes %6ld (SHAKE ok %ld, failed %ld, projected %ld, halved %ld) max strain %.1e, energy lost %.1f %% of the fall's\n",
           mode ? "halve" : "project", passes, shake_ok, shake_failed, projected, halved, strain,
           100 * (e0 - e) / (e0 - floor));
  }
  return 0;
}
