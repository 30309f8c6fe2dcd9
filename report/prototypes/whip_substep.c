// Whipping 1000:1 chain: what to do in a substep where SHAKE fails.
// 100 links of 1 cm (1 m), unit masses, tip 1000x, pinned at one end, released horizontal,
// g = 9.81, 1/64 s steps x 8 substeps, no damping, 5 s. SHAKE as the crate runs it: start-of-
// substep directions, warm start from the last substep's multipliers, Newton passes (Thomas)
// until max |C|/L <= 1e-9, at most 3 passes and each must divide the error by 10, skipped when a
// link's predicted turn has cosine < 0.99 or in the substep after a failure. Fallbacks compared:
//   project  : Newton on the position projection (current directions, no curvature of the
//              constraints: Gauss-Newton) from the prediction, lambda = 0, as the crate does;
//   halve    : the substep re-run as two half substeps, each with SHAKE (their own fallback: the
//              projection), the Verlet state converted to h/2 and back;
//   kkt      : full Newton on the projection's KKT system, M(x - x~) = J^T lambda, C(x) = 0,
//              with the constraints' curvature (lambda_k (I - n n^T)/d_k blocks): per particle
//              a node (x_j, lambda_{j-1}), block tridiagonal with 3x3 blocks (4x4 in 3D), solved
//              by block Thomas; lambda = 0 to start;
//   kkt-warm : the same, lambda starting from the last substep's multipliers;
//   fixed    : Newton with the directions frozen at the prediction's normals (exact Newton for
//              fixed directions, as SHAKE's passes are), the projection where it fails;
//   ls10     : where SHAKE fails, up to 10 more SHAKE passes with a backtracking line search on
//              sum C^2 (does SHAKE have a root there?), then the projection;
//   kkt1     : kkt-warm for the first pass only, then the projection's Gauss-Newton passes;
//   kkt1-beg : kkt1 only in substeps that begin projected (not right after SHAKE failed in the
//              same substep) and whose prediction is within 10 % (max |C|/L) — the crate's rule
//              (src/solver/direct/curvature.rs); the crate's pass costs ~5 scalar passes.
// Prints Newton passes (and those spent projecting), substeps by kind, the largest link strain,
// the energy lost of what the fall released and the CPU time (the 3x3 blocks are inverted
// naively: a KKT pass costs several scalar passes here).
//   gcc -O2 whip_substep.c -lm -o whip_substep && ./whip_substep
//   gcc -O2 -DN=200 -DTIP=1.0 whip_substep.c -lm -o whip200 && ./whip200   (the 200-link chain)
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#ifndef N
#define N 100
#endif
#ifndef TIP
#define TIP 1000.0
#endif
typedef struct { double x, y; } V;
static V x[N + 1], xp[N + 1], r[N];
static double w[N + 1], lam[N], warm[N];
static const double L = 0.01, G = 9.81, TOL = 1e-9;
static long passes, proj_passes, shake_ok, shake_failed, projected, halved;

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
static void pass_a(int shake, double alpha);
static void pass(int shake) { pass_a(shake, 1.0); }
static void pass_a(int shake, double alpha) {
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
    d[i] *= alpha;
    lam[i] += d[i];
    moveby[i].x -= dir[i].x * d[i]; moveby[i].y -= dir[i].y * d[i];
    moveby[i + 1].x += dir[i].x * d[i]; moveby[i + 1].y += dir[i].y * d[i];
  }
  for (int j = 0; j <= N; j++) { x[j].x += w[j] * moveby[j].x; x[j].y += w[j] * moveby[j].y; }
  passes++;
}
static int ls_budget = 0; static long ls_rescued, ls_passes;
static int shake_ls(void);
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
    if (k == 3 || e > 0.1 * prev) {
      if (ls_budget && shake_ls()) { ls_rescued++; return 1; }
      memcpy(x, save, sizeof save); return 0; }
    prev = e;
    pass(1);
    e = err();
  }
}
static double merit(void) {
  double e = 0;
  for (int i = 0; i < N; i++) {
    double d = hypot(x[i + 1].x - x[i].x, x[i + 1].y - x[i].y);
    e += (d - L) * (d - L);
  }
  return e;
}
// SHAKE continued by damped Newton (backtracking on sum C^2) from where it stopped.
static int shake_ls(void) {
  double e = err(), m = merit();
  for (int k = 0; k < ls_budget; k++) {
    if (e <= TOL) return 1;
    V save[N + 1]; double lsave[N];
    memcpy(save, x, sizeof save); memcpy(lsave, lam, sizeof lsave);
    double a = 1; int ok = 0;
    for (int t = 0; t < 8; t++) {
      pass_a(1, a); ls_passes++;
      double m2 = merit();
      if (m2 < m) { m = m2; ok = 1; break; }
      memcpy(x, save, sizeof save); memcpy(lam, lsave, sizeof lsave);
      a *= 0.5;
    }
    if (!ok) return 0;
    e = err();
  }
  return e <= TOL;
}
static void project(void) {
  memset(lam, 0, sizeof lam);
  for (int k = 0; k < 32 && err() > TOL; k++) { pass(0); proj_passes++; }
}

// 3x3 helpers (row-major).
typedef struct { double m[3][3]; } M3;
static M3 m3inv(M3 a) {
  M3 r;
  double det = a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
               a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
               a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
  double id = 1 / det;
  r.m[0][0] = (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) * id;
  r.m[0][1] = (a.m[0][2] * a.m[2][1] - a.m[0][1] * a.m[2][2]) * id;
  r.m[0][2] = (a.m[0][1] * a.m[1][2] - a.m[0][2] * a.m[1][1]) * id;
  r.m[1][0] = (a.m[1][2] * a.m[2][0] - a.m[1][0] * a.m[2][2]) * id;
  r.m[1][1] = (a.m[0][0] * a.m[2][2] - a.m[0][2] * a.m[2][0]) * id;
  r.m[1][2] = (a.m[0][2] * a.m[1][0] - a.m[0][0] * a.m[1][2]) * id;
  r.m[2][0] = (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]) * id;
  r.m[2][1] = (a.m[0][1] * a.m[2][0] - a.m[0][0] * a.m[2][1]) * id;
  r.m[2][2] = (a.m[0][0] * a.m[1][1] - a.m[0][1] * a.m[1][0]) * id;
  return r;
}
static M3 m3mul(M3 a, M3 b) {
  M3 r;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      r.m[i][j] = 0;
      for (int k = 0; k < 3; k++) r.m[i][j] += a.m[i][k] * b.m[k][j];
    }
  return r;
}
static void m3vec(M3 a, const double *v, double *out) {
  for (int i = 0; i < 3; i++) out[i] = a.m[i][0] * v[0] + a.m[i][1] * v[1] + a.m[i][2] * v[2];
}
static V xt[N + 1]; // the prediction (projection target)
// One Newton pass on the projection's KKT system with the constraints' curvature (lambda H):
// node j = (x_j, lambda_{j-1}), j = 1..N, block tridiagonal with 3x3 blocks.
static void kkt_pass(void) {
  static V n[N];
  static double d[N];
  static M3 A[N + 1], U[N + 1], Lo[N + 1];
  static double rhs[N + 1][3], sol[N + 1][3];
  for (int i = 0; i < N; i++) {
    double dx = x[i + 1].x - x[i].x, dy = x[i + 1].y - x[i].y;
    d[i] = hypot(dx, dy);
    n[i] = (V){dx / d[i], dy / d[i]};
  }
  for (int j = 1; j <= N; j++) {
    double m = 1 / w[j];
    // P/d scaled by lambda, for stick j-1 (before) and j (after).
    double pb[2][2], pa[2][2] = {{0, 0}, {0, 0}};
    V nb = n[j - 1];
    double lb = lam[j - 1] / d[j - 1];
    pb[0][0] = lb * (1 - nb.x * nb.x); pb[0][1] = lb * (-nb.x * nb.y);
    pb[1][0] = pb[0][1]; pb[1][1] = lb * (1 - nb.y * nb.y);
    if (j < N) {
      V na = n[j];
      double la = lam[j] / d[j];
      pa[0][0] = la * (1 - na.x * na.x); pa[0][1] = la * (-na.x * na.y);
      pa[1][0] = pa[0][1]; pa[1][1] = la * (1 - na.y * na.y);
    }
    M3 a = {{{m - pb[0][0] - pa[0][0], -pb[0][1] - pa[0][1], -nb.x},
             {-pb[1][0] - pa[1][0], m - pb[1][1] - pa[1][1], -nb.y},
             {nb.x, nb.y, 0}}};
    A[j] = a;
    M3 u = {{{0}}};
    if (j < N) {
      u.m[0][0] = pa[0][0]; u.m[0][1] = pa[0][1]; u.m[0][2] = n[j].x;
      u.m[1][0] = pa[1][0]; u.m[1][1] = pa[1][1]; u.m[1][2] = n[j].y;
    }
    U[j] = u;
    M3 lo = {{{0}}};
    if (j > 1) {
      lo.m[0][0] = pb[0][0]; lo.m[0][1] = pb[0][1];
      lo.m[1][0] = pb[1][0]; lo.m[1][1] = pb[1][1];
      lo.m[2][0] = -nb.x; lo.m[2][1] = -nb.y;
    }
    Lo[j] = lo;
    // -F_j and -C_{j-1}
    double fx = m * (x[j].x - xt[j].x) - lam[j - 1] * nb.x, fy = m * (x[j].y - xt[j].y) - lam[j - 1] * nb.y;
    if (j < N) { fx += lam[j] * n[j].x; fy += lam[j] * n[j].y; }
    rhs[j][0] = -fx; rhs[j][1] = -fy; rhs[j][2] = -(d[j - 1] - L);
  }
  // Block Thomas: D_j = A_j - Lo_j D_{j-1}^-1 U_{j-1}.
  static M3 Dinv[N + 1];
  static double y[N + 1][3];
  for (int j = 1; j <= N; j++) {
    M3 D = A[j];
    double r[3] = {rhs[j][0], rhs[j][1], rhs[j][2]};
    if (j > 1) {
      M3 t = m3mul(Lo[j], m3mul(Dinv[j - 1], U[j - 1]));
      for (int a = 0; a < 3; a++) for (int b = 0; b < 3; b++) D.m[a][b] -= t.m[a][b];
      double ly[3];
      M3 LD = m3mul(Lo[j], Dinv[j - 1]);
      m3vec(LD, y[j - 1], ly);
      for (int a = 0; a < 3; a++) r[a] -= ly[a];
    }
    Dinv[j] = m3inv(D);
    for (int a = 0; a < 3; a++) y[j][a] = r[a];
  }
  for (int j = N; j >= 1; j--) {
    double r[3] = {y[j][0], y[j][1], y[j][2]};
    if (j < N) {
      double us[3];
      m3vec(U[j], sol[j + 1], us);
      for (int a = 0; a < 3; a++) r[a] -= us[a];
    }
    m3vec(Dinv[j], r, sol[j]);
  }
  for (int j = 1; j <= N; j++) {
    x[j].x += sol[j][0]; x[j].y += sol[j][1];
    lam[j - 1] += sol[j][2];
  }
  passes++;
}
static int kkt_warm, kkt_first; // kkt_first: curvature in the first pass only
static long kkt_passes;
static void project_kkt(void) {
  memcpy(xt, x, sizeof xt);
  if (kkt_warm) memcpy(lam, warm, sizeof lam); else memset(lam, 0, sizeof lam);
  for (int k = 0; k < 32 && err() > TOL; k++) {
    if (!kkt_first || k == 0) { kkt_pass(); kkt_passes++; } else pass(0);
    proj_passes++;
  }
}
// Newton with the correction directions frozen at the prediction's normals (exact Newton for
// fixed directions, as SHAKE's passes are): returns passes, or -1 if it did not converge.
static long fixed_fail;
static int project_fixed(int warmed) {
  V save[N + 1];
  memcpy(save, x, sizeof save);
  for (int i = 0; i < N; i++) {
    double dx = x[i + 1].x - x[i].x, dy = x[i + 1].y - x[i].y, l = hypot(dx, dy);
    r[i] = (V){dx / l, dy / l};
  }
  double e0 = err();
  memset(lam, 0, sizeof lam);
  if (warmed) {
    for (int i = 0; i < N; i++) move(i, warm[i], r[i]);
    if (err() > e0) { memcpy(x, save, sizeof save); memset(lam, 0, sizeof lam); }
  }
  double e = err(), prev = INFINITY;
  for (int k = 0; k < 32; k++) {
    if (e <= TOL) return 1;
    if (e > prev) break;
    prev = e;
    pass(1); proj_passes++;
    e = err();
  }
  if (e <= TOL) return 1;
  fixed_fail++;
  memcpy(x, save, sizeof save);
  return 0;
}
static int use_fixed;
static int fell_back;
static int use_kkt, kkt_begin_only;
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
  if (use_kkt && (!kkt_begin_only || (ok == -1 && err() < 0.1))) project_kkt();
  else if (!use_fixed || !project_fixed(use_fixed == 2)) project();
  memcpy(warm, lam, sizeof warm);
  if (depth == 0) fell_back = (ok == 0);
}
int main(void) {
  const double h = 1.0 / 64 / 8;
  for (int mode = 0; mode < 10; mode++) {
    if (mode == 5 || mode == 7) continue; // (fixed directions warm-started; 40 line-search passes: as 4 and 6)
    ls_budget = mode == 6 ? 10 : mode == 7 ? 40 : 0; ls_rescued = ls_passes = 0;
    use_kkt = mode == 2 || mode == 3 || mode >= 8;
    if (mode == 6 || mode == 7) use_kkt = 0;
    kkt_warm = mode == 3 || mode >= 8;
    kkt_first = mode >= 8; kkt_begin_only = mode == 9; kkt_passes = 0;
    use_fixed = mode == 4 ? 1 : mode == 5 ? 2 : 0; fixed_fail = 0;
    for (int i = 0; i <= N; i++) { x[i] = (V){i * L, 0}; xp[i] = x[i]; w[i] = 1; }
    w[0] = 0; w[N] = 1.0 / TIP;
    memset(warm, 0, sizeof warm);
    passes = proj_passes = shake_ok = shake_failed = projected = halved = 0; fell_back = 0;
    double e0 = energy(h), floor = 0, strain = 0;
    clock_t t0 = clock();
    for (int i = 1; i <= N; i++) floor -= G * (i * L) / w[i]; // hanging straight down
    for (int s = 0; s < 64 * 5 * 8; s++) {
      substep(h, mode == 1, 0);
      strain = fmax(strain, err());
    }
    double e = energy(h);
    double cpu = (double)(clock() - t0) / CLOCKS_PER_SEC;
    printf("%-8s passes %6ld, %ld of them projecting (SHAKE ok %ld, failed %ld, projected %ld, halved %ld) max strain %.1e, energy lost %.1f %% of the fall's, %.0f ms CPU\n",
           mode == 9 ? "kkt1-beg" : mode == 8 ? "kkt1" : mode == 7 ? "ls40" : mode == 6 ? "ls10" : mode == 5 ? "fix-warm" : mode == 4 ? "fixed" : mode == 3 ? "kkt-warm" : mode == 2 ? "kkt" : mode ? "halve" : "project", passes, proj_passes, shake_ok, shake_failed, projected, halved, strain,
           100 * (e0 - e) / (e0 - floor), 1e3 * cpu);
    if (ls_budget) printf("   line search rescued %ld SHAKE substeps, %ld passes in them\n", ls_rescued, ls_passes);
    if (use_kkt) printf("   passes with the curvature: %ld\n", kkt_passes);
    if (use_fixed) printf("   fixed-direction Newton failed in %ld substeps\n", fixed_fail);
  }
  return 0;
}
