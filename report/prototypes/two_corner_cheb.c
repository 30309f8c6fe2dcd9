// Chebyshev semi-iterative acceleration (Huamin Wang 2015, ACM TOG 34(6)) measured on the
// two-corner cloth of two_corner_cloth.c (copied here with its methods (a)-(d); main runs (a) as
// the baseline and the new variants (e)-(g)).
// Build and run: gcc -O2 two_corner_cheb.c -lm -o t && ./t   (about 3 minutes; ./t all: also (b)-(d);
// ./t scan METHOD S K D rho gamma [sum|levels]: one run, METHOD 4 = (e), 5 = (f), 6 = (g), 7 = lean, 8 = HPBD)
//
// Scene (unchanged from two_corner_cloth.c): 100 x 100 particles in 2D, 5 px spacing, 980 px/s^2,
// top-left and top-right particles pinned, released flat, 1/64 s steps with S substeps, 5 s. Max
// strain while falling (t < 4 s) and hanging (t = 4..5 s); the stick with the largest strain at
// the end; cost as CPU time per step relative to the colour-order Gauss-Seidel sweep at 8
// substeps x 1 sweep in the same run.
//
// New variants, K iterations per substep, Wang's recurrence with a delay of D plain iterations:
//   x^{k+1} = omega_{k+1} (gamma (xhat^{k+1} - x^k) + x^k - x^{k-1}) + x^{k-1},
//   omega = 1 for the first D iterations, then 2/(2 - rho^2), then 4/(4 - rho^2 omega).
// (e) xhat from a Jacobi PBD iteration: every stick's correction from the same positions,
//     accumulated and divided by the particle's number of sticks (constraint averaging).
// (f) xhat from one colour-order Gauss-Seidel sweep (the crate's sweep).
// (g) xhat from one hierarchical PBD cycle (hpbd_grid.c: unilateral coarse levels, coarsest
//     first, bilinear prolongation, then the fine colour sweep).
// Energy: E = sum (|v|^2 / 2 + g (y - y0)) over free particles (unit masses), v from the last
// substep; E starts at 0 and PBD should only lose it. Reported: the fall's peak kinetic energy
// KEpk (t < 4 s), the largest kinetic energy in the last second as % of KEpk, and the largest E
// over the run as % of KEpk (> 0: the scene gained energy).
//
// Cost units. "x": the prototype's colour sweep at S=8 (as two_corner_cloth.c). That sweep measures
// each stick twice, once with hypot(); "lean" is the same sweep (same figures) with one sqrt, and
// costs 0.4x. Jacobi, the sweep inside (f) and the hierarchy all use one sqrt, so compare them in
// lean units (or against the lean sweeps listed): in "x" they look 2.5 times cheaper than they are.
//
// Result (two_corner_cheb.txt; scans in scan_grid.txt). Nothing reaches < 10 % at <= 1.5x. Best
// (falling / hanging) by band, x units: <= 1.5x: (f) S=8 K=4 rho .9 gamma 1: 87 / 39 % (plain
// lean S=32: 55 / 23 % at 1.3x), (e) S=8 K=4 rho .9 gamma 2: 162 / 99 %, (g) S=8 K=2 rho .5:
// 44 / 22 % (plain HPBD S=16: 35 / 18 % at 1.3x); <= 3x: (g) S=8 K=4 rho .9: 22 / 11 %, (f) S=8 K=8
// rho .95: 38 / 17 %; <= 12x: (e) S=16 K=16 rho .99 gamma 2: 9.0 / 5.4 % at 10.5x (26.6x lean; the
// lean sweep at S=128 gives 10 / 6 % at 5.1x). Chebyshev speeds up iterations within a substep
// (S=8 x 16 GS sweeps: 54 / 23 % plain, 14 / 8.8 % accelerated) but the same sweeps spent on
// substeps do as well or better (S=128: 10 / 6 %). It needs K >= 4 (K = 2 diverged for every
// rho >= 0.9), rho <= 0.9 for K = 4..8 and <= 0.99 for K = 16..32 (rho >= 0.999 always diverged);
// some stable-looking runs gain energy (E > 0). The hierarchy of hpbd_grid.c gains energy itself
// (E up to +74..130 % of the fall's peak kinetic energy around t = 0.6..0.9 s).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
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


// ---------------------------------------------------------------------------------------------
// (e)-(g): Chebyshev semi-iterative acceleration.
static V xprev_it[NP], xk[NP], acc[NP], x0[NP];
static double deg[NP];
static void build_degree(void) {
  memset(deg, 0, sizeof deg);
  for (int k = 0; k < NC; k++) { deg[ca[k]] += 1; deg[cb[k]] += 1; }
}
// One Jacobi iteration's summed corrections into acc (from the current x, x unchanged).
static void jacobi_corrections(void) {
  memset(acc, 0, sizeof acc);
  for (int k = 0; k < NC; k++) {
    int a = ca[k], b = cb[k];
    double wa = w[a], wb = w[b];
    if (wa + wb == 0) continue;
    double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, d = sqrt(dx * dx + dy * dy);
    double l = -(d - L) / (wa + wb) / d;  // times (dx, dy) = correction along the normal
    acc[a].x -= wa * dx * l; acc[a].y -= wa * dy * l; acc[b].x += wb * dx * l; acc[b].y += wb * dy * l;
  }
}
// Reference: the same colour-order sweep with one square root per stick and no hypot (the
// prototype's sweep computes the length twice, once with hypot): how much of the Jacobi
// iteration's lower cost below is only that.
static void lean_sweep(void) {
  for (int i = 0; i < NC; i++) {
    int k = colour_order[i], a = ca[k], b = cb[k];
    double wa = w[a], wb = w[b];
    if (wa + wb == 0) continue;
    double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, d = sqrt(dx * dx + dy * dy);
    double l = -(d - L) / (wa + wb) / d;
    x[a].x -= wa * dx * l; x[a].y -= wa * dy * l; x[b].x += wb * dx * l; x[b].y += wb * dy * l;
  }
}
static double next_omega(int k, int delay, double rho, double omega) {
  if (k < delay) return 1;
  if (k == delay) return 2 / (2 - rho * rho);
  return 4 / (4 - rho * rho * omega);
}
// ---- hierarchy of hpbd_grid.c (grid levels: every other line plus the last, down to 3 x 3) ----
#define MAXL 8
static V before[NP];
static int ncol[MAXL], nrow[MAXL], cols[MAXL][W], rows[MAXL][H], nlev;
static double wl[MAXL][NP];
static void build_levels(void) {
  ncol[0] = W; nrow[0] = H;
  for (int c = 0; c < W; c++) cols[0][c] = c;
  for (int r = 0; r < H; r++) rows[0][r] = r;
  nlev = 1;
  while (ncol[nlev - 1] > 3 && nlev < MAXL) {
    int l = nlev, n = 0;
    for (int i = 0; i < ncol[l - 1]; i += 2) cols[l][n++] = cols[l - 1][i];
    if (cols[l][n - 1] != cols[l - 1][ncol[l - 1] - 1]) cols[l][n++] = cols[l - 1][ncol[l - 1] - 1];
    ncol[l] = n; n = 0;
    for (int i = 0; i < nrow[l - 1]; i += 2) rows[l][n++] = rows[l - 1][i];
    if (rows[l][n - 1] != rows[l - 1][nrow[l - 1] - 1]) rows[l][n++] = rows[l - 1][nrow[l - 1] - 1];
    nrow[l] = n; nlev++;
  }
}
static void bracket(const int *lines, int n, int g, int *i0, int *i1, double *t) {
  int k = 0; while (k + 1 < n && lines[k + 1] <= g) k++;
  if (lines[k] == g || k + 1 >= n) { *i0 = *i1 = lines[k]; *t = 0; return; }
  *i0 = lines[k]; *i1 = lines[k + 1]; *t = (double)(g - lines[k]) / (lines[k + 1] - lines[k]);
}
static int on_level(int l, int c, int r) {
  int a = 0, b = 0;
  for (int i = 0; i < ncol[l]; i++) a |= cols[l][i] == c;
  for (int i = 0; i < nrow[l]; i++) b |= rows[l][i] == r;
  return a && b;
}
typedef struct { int p[4]; double wt[4]; int child; } Interp;
static Interp *interp[MAXL]; static int ninterp[MAXL];
static void build_interp(void) {
  for (int l = 1; l < nlev; l++) {
    interp[l] = malloc(sizeof(Interp) * NP); ninterp[l] = 0;
    for (int ri = 0; ri < nrow[l - 1]; ri++) for (int ci = 0; ci < ncol[l - 1]; ci++) {
      int c = cols[l - 1][ci], r = rows[l - 1][ri];
      if (on_level(l, c, r)) continue;
      int c0, c1, r0, r1; double tc, tr;
      bracket(cols[l], ncol[l], c, &c0, &c1, &tc); bracket(rows[l], nrow[l], r, &r0, &r1, &tr);
      Interp it = {{idx(c0, r0), idx(c1, r0), idx(c0, r1), idx(c1, r1)}, {(1 - tc) * (1 - tr), tc * (1 - tr), (1 - tc) * tr, tc * tr}, idx(c, r)};
      interp[l][ninterp[l]++] = it;
    }
  }
}
static void build_level_masses(void) {  // w[] is fixed (two corners), so once
  static double mass[NP];
  for (int i = 0; i < NP; i++) { mass[i] = 1; wl[0][i] = w[i]; }
  for (int l = 1; l < nlev; l++) {
    for (int k = 0; k < ninterp[l]; k++) {
      Interp *it = &interp[l][k];
      for (int q = 0; q < 4; q++) mass[it->p[q]] += it->wt[q] * mass[it->child];
    }
    for (int i = 0; i < NP; i++) wl[l][i] = w[i] == 0 ? 0 : 1 / mass[i];
  }
}
static void project(int a, int b, double rest, const double *iw, int unilateral) {
  double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, d = sqrt(dx * dx + dy * dy), ws = iw[a] + iw[b];
  if (ws == 0 || (unilateral && d <= rest)) return;
  double l = -(d - rest) / ws, nx = dx / d, ny = dy / d;
  x[a].x -= iw[a] * nx * l; x[a].y -= iw[a] * ny * l; x[b].x += iw[b] * nx * l; x[b].y += iw[b] * ny * l;
}
static void sweep_level(int l) {
  int nc = ncol[l], nr = nrow[l];
  for (int par = 0; par < 2; par++) for (int ri = 0; ri < nr; ri++) for (int ci = par; ci + 1 < nc; ci += 2)
    project(idx(cols[l][ci], rows[l][ri]), idx(cols[l][ci + 1], rows[l][ri]), (cols[l][ci + 1] - cols[l][ci]) * L, wl[l], l > 0);
  for (int par = 0; par < 2; par++) for (int ri = par; ri + 1 < nr; ri += 2) for (int ci = 0; ci < nc; ci++)
    project(idx(cols[l][ci], rows[l][ri]), idx(cols[l][ci], rows[l][ri + 1]), (rows[l][ri + 1] - rows[l][ri]) * L, wl[l], l > 0);
}
static void hierarchy(int levels) {  // coarse levels (coarsest first), then the fine colour sweep
  int top = levels < nlev - 1 ? levels : nlev - 1;
  for (int l = top; l >= 1; l--) {
    for (int ri = 0; ri < nrow[l]; ri++) for (int ci = 0; ci < ncol[l]; ci++) { int i = idx(cols[l][ci], rows[l][ri]); before[i] = x[i]; }
    sweep_level(l);
    for (int k = 0; k < ninterp[l]; k++) {
      Interp *it = &interp[l][k]; V d = {0, 0};
      for (int q = 0; q < 4; q++) { d.x += it->wt[q] * (x[it->p[q]].x - before[it->p[q]].x); d.y += it->wt[q] * (x[it->p[q]].y - before[it->p[q]].y); }
      if (w[it->child] != 0) { x[it->child].x += d.x; x[it->child].y += d.y; }
    }
  }
  sweep_level(0);
}

// One substep's K accelerated iterations (x holds the prediction on entry).
enum { SWEEP, WARM, DEPTH, NEWTON, CHEB_JACOBI, CHEB_GS, CHEB_HPBD, LEAN, HPBD };
typedef struct { int method, substeps, iters, delay, levels, sum; double rho, gamma, param; int passes, cg; } Cfg;
static void cheb_substep(const Cfg *c) {
  memcpy(xprev_it, x, sizeof x);  // x^{-1} = x^0 (unused while omega = 1)
  double omega = 1;
  for (int k = 0; k < c->iters; k++) {
    omega = next_omega(k, c->delay, c->rho, omega);
    if (c->method == CHEB_JACOBI) {
      jacobi_corrections();
      for (int i = 0; i < NP; i++) {
        double s = c->gamma / (c->sum ? 1 : deg[i]);
        V xh = {x[i].x + s * acc[i].x, x[i].y + s * acc[i].y};
        V xn = {omega * (xh.x - xprev_it[i].x) + xprev_it[i].x, omega * (xh.y - xprev_it[i].y) + xprev_it[i].y};
        xprev_it[i] = x[i]; x[i] = xn;
      }
    } else {
      memcpy(xk, x, sizeof x);
      if (c->method == CHEB_GS) lean_sweep(); else hierarchy(c->levels);
      for (int i = 0; i < NP; i++) {
        V xh = {xk[i].x + c->gamma * (x[i].x - xk[i].x), xk[i].y + c->gamma * (x[i].y - xk[i].y)};
        x[i] = (V){omega * (xh.x - xprev_it[i].x) + xprev_it[i].x, omega * (xh.y - xprev_it[i].y) + xprev_it[i].y};
        xprev_it[i] = xk[i];
      }
    }
  }
}

static double sweep_ms, lean_ms;
static const char *names[] = {"colour sweep", "warm-started sweep", "depth-ordered sweep", "Newton + line-PCG", "(e) Cheb-Jacobi", "(f) Cheb-GS", "(g) Cheb-HPBD", "lean colour sweep", "HPBD (no Cheb)"};
typedef struct { double falling, hanging, cost, ke_peak, ke_late, e_max; int worst, diverged, e_step; } Result;
static Result run(Cfg c) {
  init(); mu = c.param;
  for (int i = 0; i < NP; i++) x0[i] = x[i];
  double h = 1.0 / 64 / c.substeps;
  Result r = {0};
  clock_t t0 = clock();
  for (int step = 1; step <= 320; step++) {
    for (int s = 0; s < c.substeps; s++) {
      predict(h);
      if (c.method == SWEEP) for (int p = 0; p < c.iters; p++) sweep(colour_order, 1);
      if (c.method == WARM) { warm_start(c.param); sweep(colour_order, 1); }
      if (c.method == DEPTH) sweep(depth_order, c.param);
      if (c.method == NEWTON) for (int p = 0; p < c.passes; p++) newton_pass(c.cg);
      if (c.method == LEAN) for (int p = 0; p < c.iters; p++) lean_sweep();
      if (c.method == HPBD) for (int p = 0; p < c.iters; p++) hierarchy(c.levels);
      if (c.method >= CHEB_JACOBI && c.method <= CHEB_HPBD) cheb_substep(&c);
    }
    double m = 0; for (int k = 0; k < NC; k++) m = fmax(m, strain(k));
    if (!isfinite(x[idx(W / 2, H - 1)].y) || !isfinite(m) || m > 1e6) { r.diverged = step; break; }  // diverged
    if (step > 256) r.hanging = fmax(r.hanging, m); else r.falling = fmax(r.falling, m);
    double ke = 0, e = 0;
    for (int i = 0; i < NP; i++) {
      if (w[i] == 0) continue;
      double vx = (x[i].x - xp[i].x) / h, vy = (x[i].y - xp[i].y) / h, k2 = 0.5 * (vx * vx + vy * vy);
      ke += k2; e += k2 + G * (x[i].y - x0[i].y);
    }
    if (step > 256) r.ke_late = fmax(r.ke_late, ke); else r.ke_peak = fmax(r.ke_peak, ke);
    if (e > r.e_max) { r.e_max = e; r.e_step = step; }
  }
  double ms = 1000.0 * (clock() - t0) / CLOCKS_PER_SEC / 320;
  if (c.method == SWEEP && c.substeps == 8 && c.iters == 1) sweep_ms = ms;
  if (c.method == LEAN && c.substeps == 8 && c.iters == 1) lean_ms = ms;
  r.cost = ms / sweep_ms;
  for (int k = 0; k < NC; k++) if (strain(k) > strain(r.worst)) r.worst = k;
  char label[96], when[32];
  if (c.method == SWEEP || c.method == LEAN) snprintf(label, sizeof label, "%-18s S=%3d K=%2d", names[c.method], c.substeps, c.iters);
  else if (c.method == HPBD) snprintf(label, sizeof label, "%-18s S=%3d K=%2d lv %d", names[c.method], c.substeps, c.iters, c.levels);
  else if (c.method <= NEWTON) snprintf(label, sizeof label, "%-18s S=%3d param %g passes %d x %d CG", names[c.method], c.substeps, c.param, c.passes, c.cg);
  else if (c.method == CHEB_HPBD) snprintf(label, sizeof label, "%-18s S=%3d K=%2d D=%d rho %-6g gamma %-4g lv %d", names[c.method], c.substeps, c.iters, c.delay, c.rho, c.gamma, c.levels);
  else snprintf(label, sizeof label, "%-18s S=%3d K=%2d D=%d rho %-6g gamma %-4g%s", names[c.method], c.substeps, c.iters, c.delay, c.rho, c.gamma, c.sum ? " sum" : "");
  if (r.diverged) { printf("%-62s | diverged after %3d of 320 steps               | %5.1fx\n", label, r.diverged, r.cost); fflush(stdout); return r; }
  printf("%-62s | falling %9.3g %% hanging %9.3g %% | worst (%d,%d)-(%d,%d) | %5.1fx (%5.1fx lean) | KEpk %.3g late %5.1f %% Emax %+.2g %%%s\n",
         label, r.falling * 100, r.hanging * 100, ca[r.worst] % W, ca[r.worst] / W, cb[r.worst] % W, cb[r.worst] / W, r.cost, lean_ms > 0 ? ms / lean_ms : 0,
         r.ke_peak, 100 * r.ke_late / r.ke_peak, 100 * r.e_max / r.ke_peak, r.e_step ? (snprintf(when, sizeof when, " at t=%.2f s", r.e_step / 64.0), when) : "");
  fflush(stdout);
  return r;
}
static Cfg base(int substeps, int iters) { return (Cfg){SWEEP, substeps, iters, 0, 0, 0, 0, 1, 0, 0, 0}; }
static Cfg cheb(int method, int substeps, int iters, int delay, double rho, double gamma) {
  return (Cfg){method, substeps, iters, delay, 6, 0, rho, gamma, 0, 0, 0};
}
int main(int argc, char **argv) {
  build(); build_degree(); build_levels(); build_interp(); init(); build_level_masses();
  const char *mode = argc > 1 ? argv[1] : "default";
  run(base(8, 1));
  Cfg lean = base(8, 1); lean.method = LEAN; run(lean);
  if (!strcmp(mode, "scan")) {  // exploration: argv[2..] = method S K D rho gamma [sum|levels]
    Cfg c = cheb(atoi(argv[2]), atoi(argv[3]), atoi(argv[4]), atoi(argv[5]), atof(argv[6]), atof(argv[7]));
    if (argc > 8) { if (c.method >= CHEB_HPBD) c.levels = atoi(argv[8]); else c.sum = atoi(argv[8]); }
    if (c.method == LEAN || c.method == SWEEP || c.method == HPBD) c.iters = atoi(argv[4]);
    run(c);
    return 0;
  }
  // Baselines: the prototype's sweep (cost unit "x") and the same sweep with one sqrt (unit "lean").
  run(base(16, 1)); run(base(32, 1)); run(base(128, 1));
  int lean_s[][2] = {{12, 1}, {16, 1}, {32, 1}, {128, 1}, {8, 4}, {8, 16}, {4, 4}, {2, 4}};
  for (int i = 0; i < 8; i++) { Cfg c = base(lean_s[i][0], lean_s[i][1]); c.method = LEAN; run(c); }
  int hp_s[][2] = {{8, 1}, {16, 1}, {32, 1}, {8, 2}, {8, 4}};
  for (int i = 0; i < 5; i++) { Cfg c = base(hp_s[i][0], hp_s[i][1]); c.method = HPBD; c.levels = 6; run(c); }
  printf("\n(e) Chebyshev-Jacobi (averaged), D=1, K x S grid at rho 0.9 and 0.99, gamma 1.5\n");
  int Ss[] = {8, 4, 2, 1}, Ks[] = {1, 2, 4, 8, 16};
  for (int a = 0; a < 4; a++) for (int b = 0; b < 5; b++) for (int r = 0; r < 2; r++) {
    if (Ks[b] == 1 && r) continue;  // K = 1: no acceleration possible, plain Jacobi
    run(cheb(CHEB_JACOBI, Ss[a], Ks[b], 1, Ks[b] == 1 ? 0 : r ? 0.99 : 0.9, 1.5));
  }
  printf("(e) best settings found in the scan (scan_grid.txt), and more iterations\n");
  run(cheb(CHEB_JACOBI, 8, 4, 1, 0.9, 2.0));
  run(cheb(CHEB_JACOBI, 8, 4, 1, 0.95, 2.0));
  { Cfg c = cheb(CHEB_JACOBI, 8, 4, 1, 0.9, 0.45); c.sum = 1; run(c); }
  run(cheb(CHEB_JACOBI, 8, 8, 1, 0.97, 2.0));
  run(cheb(CHEB_JACOBI, 8, 16, 1, 0.99, 2.0));
  run(cheb(CHEB_JACOBI, 8, 16, 1, 0.999, 2.0));
  run(cheb(CHEB_JACOBI, 16, 8, 1, 0.97, 2.0));
  run(cheb(CHEB_JACOBI, 16, 16, 1, 0.99, 2.0));
  run(cheb(CHEB_JACOBI, 8, 32, 1, 0.995, 2.0));
  run(cheb(CHEB_JACOBI, 2, 16, 1, 0.99, 1.5));  // gains energy
  printf("\n(f) Chebyshev on the colour-order Gauss-Seidel sweep, D=1, K x S grid at rho 0.9 and 0.99, gamma 1\n");
  for (int a = 0; a < 4; a++) for (int b = 1; b < 5; b++) for (int r = 0; r < 2; r++)
    run(cheb(CHEB_GS, Ss[a], Ks[b], 1, r ? 0.99 : 0.9, 1.0));
  printf("(f) delay and rho\n");
  run(cheb(CHEB_GS, 4, 16, 2, 0.99, 1.0));
  run(cheb(CHEB_GS, 1, 16, 2, 0.99, 1.0));
  run(cheb(CHEB_GS, 8, 16, 1, 0.999, 1.0));
  run(cheb(CHEB_GS, 8, 4, 1, 0.95, 1.0));
  run(cheb(CHEB_GS, 8, 8, 1, 0.95, 1.0));
  printf("\n(g) Chebyshev on the hierarchical cycle of hpbd_grid.c (6 coarse levels), D=1, gamma 1\n");
  double g_rho[] = {0.5, 0.9, 0.99};
  int g_s[][2] = {{4, 2}, {8, 2}, {2, 4}, {4, 4}, {8, 4}, {2, 8}, {8, 8}};
  for (int i = 0; i < 7; i++) for (int r = 0; r < 3; r++) run(cheb(CHEB_HPBD, g_s[i][0], g_s[i][1], 1, g_rho[r], 1.0));
  printf("\nrepeat of the unit: ");
  run(base(8, 1));
  if (!strcmp(mode, "all")) {  // the original (b)-(d) of two_corner_cloth.c
    double gammas[] = {0.3, 0.6}, scales[] = {0.1, 0.0}, mus[] = {1e-2, 1e-1};
    for (int i = 0; i < 2; i++) { Cfg c = base(8, 1); c.method = WARM; c.param = gammas[i]; run(c); }
    for (int i = 0; i < 2; i++) { Cfg c = base(8, 1); c.method = DEPTH; c.param = scales[i]; run(c); }
    for (int i = 0; i < 2; i++) { Cfg c = base(8, 1); c.method = NEWTON; c.param = mus[i]; c.passes = 3; c.cg = 10; run(c); }
  }
  return 0;
}
