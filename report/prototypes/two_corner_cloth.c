// Why a cloth hung by its two top corners stretches, and three remedies measured (none kept).
// Build and run: gcc -O2 two_corner_cloth.c -lm -o two_corner_cloth && ./two_corner_cloth
//
// Scene (as ../../../shared/reference/prototypes/cloth_lines_cases.c, which reproduces the
// crate's swept figures): 100 x 100 particles in 2D, 5 px spacing, 980 px/s^2, top-left and
// top-right particles pinned, released flat, 1/64 s steps with S substeps, 5 s. Max strain while
// falling (t < 4 s) and hanging (t = 4..5 s); the stick with the largest strain; cost as CPU time
// per step relative to one colour-order Gauss-Seidel sweep at 8 substeps in the same run.
//
// Methods: (a) colour-order sweep (the crate's cloth); (b) the sweep with lambda warm-started from
// the previous substep, scaled by gamma; (c) the sweep in order of graph depth from the pins with
// the parent end's inverse mass scaled by s (shock propagation / follow-the-leader); (d) a global
// Newton projection: per pass, (J W J^T + mu I) dl = -C solved by conjugate gradients
// preconditioned with every row's and every column's tridiagonal block (the crate's line solve).
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#define W 100
#define H 100
#define NP (W * H)
#define NH ((W - 1) * H)
#define NC (NH + W * (H - 1))
typedef struct { double x, y; } V;
static V x[NP], xp[NP], nrm[NC], u[NP];
static double w[NP], lam[NC], C[NC], res[NC], z[NC], dir[NC], Ad[NC], dl[NC];
static int ca[NC], cb[NC], colour_order[NC], depth_order[NC], depth[NP];
static const double L = 5.0, G = 980.0;
static int idx(int c, int r) { return r * W + c; }

// Sticks numbered by line (rows, then columns) so a line's sticks are consecutive; two orders.
static void build(void) {
  int k = 0, n = 0;
  for (int r = 0; r < H; r++) for (int c = 0; c + 1 < W; c++) { ca[k] = idx(c, r); cb[k] = idx(c + 1, r); k++; }
  for (int c = 0; c < W; c++) for (int r = 0; r + 1 < H; r++) { ca[k] = idx(c, r); cb[k] = idx(c, r + 1); k++; }
  for (int par = 0; par < 2; par++) for (int r = 0; r < H; r++) for (int c = par; c + 1 < W; c += 2) colour_order[n++] = r * (W - 1) + c;
  for (int par = 0; par < 2; par++) for (int r = par; r + 1 < H; r += 2) for (int c = 0; c < W; c++) colour_order[n++] = NH + c * (H - 1) + r;
  for (int r = 0; r < H; r++) for (int c = 0; c < W; c++) depth[idx(c, r)] = r + (c < W - 1 - c ? c : W - 1 - c);
  n = 0;  // stable by the smaller end's depth, colour order within a depth
  for (int d = 0; d <= W + H; d++) for (int i = 0; i < NC; i++) {
    int k = colour_order[i], dk = depth[ca[k]] < depth[cb[k]] ? depth[ca[k]] : depth[cb[k]];
    if (dk == d) depth_order[n++] = k;
  }
}
static void init(void) {
  for (int r = 0; r < H; r++) for (int c = 0; c < W; c++) {
    int i = idx(c, r); x[i] = (V){c * L, -r * L}; xp[i] = x[i];
    w[i] = (r == 0 && (c == 0 || c == W - 1)) ? 0 : 1;
  }
  memset(lam, 0, sizeof lam);
}
static void predict(double h) {
  for (int i = 0; i < NP; i++) {
    if (w[i] == 0) continue;
    V v = {x[i].x - xp[i].x, x[i].y - xp[i].y}; xp[i] = x[i];
    x[i].x += v.x; x[i].y += v.y - G * h * h;
  }
}
static void move(int k, double wa, double wb, double l) {
  int a = ca[k], b = cb[k];
  double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, d = sqrt(dx * dx + dy * dy), nx = dx / d, ny = dy / d;
  x[a].x -= wa * nx * l; x[a].y -= wa * ny * l; x[b].x += wb * nx * l; x[b].y += wb * ny * l;
}
static double strain(int k) { return hypot(x[cb[k]].x - x[ca[k]].x, x[cb[k]].y - x[ca[k]].y) / L - 1; }

// (a), (b), (c): one Gauss-Seidel sweep; parent_scale < 1 only in depth order.
static void sweep(const int *order, double parent_scale) {
  for (int i = 0; i < NC; i++) {
    int k = order[i], a = ca[k], b = cb[k];
    double wa = w[a], wb = w[b];
    if (depth[a] < depth[b]) wa *= parent_scale; else if (depth[b] < depth[a]) wb *= parent_scale;
    if (wa + wb == 0) continue;
    double d = -strain(k) * L / (wa + wb);
    move(k, wa, wb, d);
    lam[k] += d;
  }
}
static void warm_start(double gamma) {
  for (int k = 0; k < NC; k++) { lam[k] *= gamma; move(k, w[ca[k]], w[cb[k]], lam[k]); }
}

// (d): global Newton projection with line-preconditioned conjugate gradients.
static double mu;
static void linearise(void) {
  for (int k = 0; k < NC; k++) {
    double dx = x[cb[k]].x - x[ca[k]].x, dy = x[cb[k]].y - x[ca[k]].y, d = sqrt(dx * dx + dy * dy);
    nrm[k] = (V){dx / d, dy / d}; C[k] = d - L;
  }
}
static void spread(const double *v) {  // u = W J^T v
  memset(u, 0, sizeof u);
  for (int k = 0; k < NC; k++) {
    u[ca[k]].x -= nrm[k].x * v[k]; u[ca[k]].y -= nrm[k].y * v[k];
    u[cb[k]].x += nrm[k].x * v[k]; u[cb[k]].y += nrm[k].y * v[k];
  }
  for (int i = 0; i < NP; i++) { u[i].x *= w[i]; u[i].y *= w[i]; }
}
static void matvec(const double *v, double *out) {  // (J W J^T + mu) v
  spread(v);
  for (int k = 0; k < NC; k++) out[k] = nrm[k].x * (u[cb[k]].x - u[ca[k]].x) + nrm[k].y * (u[cb[k]].y - u[ca[k]].y) + mu * v[k];
}
static void line_solve(int k0, int m, const double *rhs, double *out) {  // Thomas on one line's block
  static double bb[W + H], cc[W + H], yy[W + H];
  for (int i = 0; i < m; i++) {
    int k = k0 + i;
    double diag = w[ca[k]] + w[cb[k]] + mu, rhs_i = rhs[k];
    double sub = i > 0 ? -w[ca[k]] * (nrm[k - 1].x * nrm[k].x + nrm[k - 1].y * nrm[k].y) : 0;
    if (i > 0) { double f = sub / bb[i - 1]; diag -= f * cc[i - 1]; rhs_i -= f * yy[i - 1]; }
    bb[i] = diag; yy[i] = rhs_i;
    cc[i] = i < m - 1 ? -w[cb[k]] * (nrm[k].x * nrm[k + 1].x + nrm[k].y * nrm[k + 1].y) : 0;
  }
  out[k0 + m - 1] = yy[m - 1] / bb[m - 1];
  for (int i = m - 2; i >= 0; i--) out[k0 + i] = (yy[i] - cc[i] * out[k0 + i + 1]) / bb[i];
}
static void precondition(const double *r, double *out) {
  for (int r_ = 0; r_ < H; r_++) line_solve(r_ * (W - 1), W - 1, r, out);
  for (int c = 0; c < W; c++) line_solve(NH + c * (H - 1), H - 1, r, out);
}
static double dot(const double *a, const double *b) { double s = 0; for (int k = 0; k < NC; k++) s += a[k] * b[k]; return s; }
static void newton_pass(int iterations) {
  linearise();
  memset(dl, 0, sizeof dl);
  for (int k = 0; k < NC; k++) res[k] = -C[k];
  precondition(res, z); memcpy(dir, z, sizeof dir);
  double rz = dot(res, z);
  for (int it = 0; it < iterations && rz > 0; it++) {
    matvec(dir, Ad);
    double alpha = rz / dot(dir, Ad);
    for (int k = 0; k < NC; k++) { dl[k] += alpha * dir[k]; res[k] -= alpha * Ad[k]; }
    precondition(res, z);
    double rz_next = dot(res, z), beta = rz_next / rz; rz = rz_next;
    for (int k = 0; k < NC; k++) dir[k] = z[k] + beta * dir[k];
  }
  spread(dl);
  for (int i = 0; i < NP; i++) { x[i].x += u[i].x; x[i].y += u[i].y; }
}

enum { SWEEP, WARM, DEPTH, NEWTON };
static double sweep_ms;
static void run(int method, int substeps, double param, int passes, int iterations) {
  init(); mu = param;
  double h = 1.0 / 64 / substeps, falling = 0, hanging = 0;
  clock_t t0 = clock();
  for (int step = 1; step <= 320; step++) {
    for (int s = 0; s < substeps; s++) {
      predict(h);
      if (method == SWEEP) sweep(colour_order, 1);
      if (method == WARM) { warm_start(param); sweep(colour_order, 1); }
      if (method == DEPTH) sweep(depth_order, param);
      if (method == NEWTON) for (int p = 0; p < passes; p++) newton_pass(iterations);
    }
    double m = 0; for (int k = 0; k < NC; k++) m = fmax(m, strain(k));
    if (!isfinite(x[idx(W / 2, H - 1)].y) || m > 1e6) { falling = hanging = INFINITY; break; }  // diverged
    if (step > 256) hanging = fmax(hanging, m); else falling = fmax(falling, m);
  }
  double ms = 1000.0 * (clock() - t0) / CLOCKS_PER_SEC / 320;
  if (method == SWEEP && substeps == 8) sweep_ms = ms;
  int worst = 0; for (int k = 0; k < NC; k++) if (strain(k) > strain(worst)) worst = k;
  if (isinf(falling)) { printf("%-20s S=%3d param %-6g passes %d x %2d CG | diverged\n", method == WARM ? "warm-started sweep" : method == DEPTH ? "depth-ordered sweep" : "Newton + line-PCG", substeps, param, passes, iterations); return; }
  const char *names[] = {"colour sweep", "warm-started sweep", "depth-ordered sweep", "Newton + line-PCG"};
  printf("%-20s S=%3d param %-6g passes %d x %2d CG | falling %10.3g %% hanging %10.3g %% | worst stick (%d,%d)-(%d,%d) | %5.1fx\n",
         names[method], substeps, param, passes, iterations, falling * 100, hanging * 100,
         ca[worst] % W, ca[worst] / W, cb[worst] % W, cb[worst] / W, ms / sweep_ms);
  fflush(stdout);
}
int main(void) {
  build();
  run(SWEEP, 8, 0, 0, 0);
  run(SWEEP, 16, 0, 0, 0);
  run(SWEEP, 32, 0, 0, 0);
  run(SWEEP, 128, 0, 0, 0);
  double gammas[] = {0.3, 0.6, 0.7, 0.75};
  for (int i = 0; i < 4; i++) run(WARM, 8, gammas[i], 0, 0);
  double scales[] = {0.5, 0.1, 0.0};
  for (int i = 0; i < 3; i++) run(DEPTH, 8, scales[i], 0, 0);
  double mus[] = {1e-9, 1e-2, 1e-1};
  for (int i = 0; i < 3; i++) { run(NEWTON, 8, mus[i], 1, 10); run(NEWTON, 8, mus[i], 3, 10); }
  return 0;
}
