// The energy of ngsgel.GelShell (its area term and its default edge term) as compiled NGSolve
// BilinearFormIntegrators: ngsgel/shell.py builds them for kernels="compiled" in place of the
// Variation of the same energy, which stays the reference model. ngsgel/kernels/loader.py compiles
// this file against the installed NGSolve at first use. The gel law W' below repeats
// FloryRehnerGel.swollen_energy (ngsgel/materials.py); tests/test_shell_kernels.py pins the two
// together through the energy, residual and tangent.
//
// Why compiled kernels: the symbolic tangent differentiates the through-thickness gel law with the
// surface Hessian of u inside it twice, at every point. Here one kernel per quadrature point gives
// the energy density, its gradient and its Hessian in the point's local unknowns r, and the
// integrator maps them to the element energy, residual (ApplyElementMatrix) and tangent
// (CalcLinearizedElementMatrix) with the trial proxies' own differential operators
// (Grad(u).Trace(), u.Operator("hesseboundary"), the thickness stretches or the hybrid rotation's
// trace), so curved elements are handled exactly as by the symbolic forms: the element matrix is
// sum_points w B^T (d2psi/dr2) B with B = dr/d(element dofs). B depends on the reference geometry
// only and is kept per element after its first evaluation, in two blocks on the dofs each reaches
// (memory: about 3 kB per unknown at order 3, 150 MB on the 50k-unknown half cap, where it took
// the energy from 0.118 to 0.053 s and the residual from 0.132 to 0.069 s on two threads).
//
// Local unknowns, in an orthonormal tangent frame (T1, T2, N) at the point, f_a = Fm T_a:
//   r[0..5]   f_a - T_a = grad_u T_a,
//   r[6..14]  h_{i,s} = T_a . Sym(hesse u_i) T_b for s = (a, b) in (11, 12, 22), index 6 + 3 i + s,
//   area: r[15..] the thickness stretches lam_q;  edge: r[15] omega . mu_ref.
// The deformed curvature S_s = (n.N) W_s - n . h_s (n = f_1 x f_2 / |f_1 x f_2|, W the reference
// Weingarten map in the frame) carries all dependence on h, so each energy is a function phi of
// fewer reduced variables y(r). Its Hessian is J^T phi'' J + sum_k phi'_k y_k'' (J = dy/dr): phi''
// by second-order jets in y (Jet2: 8 or 10 variables instead of 17 or 16), y'' written out (S''
// through n(f), by AutoDiffDiff<6>).
//
// Area: per layer q, (Fm + zeta lever Fm C^+ S) A^-1 = f M_q with
// M_q = (I + zeta lever a^-1 S)(I + zeta W)^-1 and a = f^T f, so |F_q|^2 = tr(M^T a M) + lam_q^2 and
// det F_q = lam_q det M sqrt(det a): y = (a_11, a_12, a_22, S, lam_1 .. lam_NL).
// Edge (linearised moment): y = (f - T, S, omega . mu_ref).
#include <comp.hpp>
#include <python_comp.hpp>
using namespace ngfem;

// Thickness points of the area kernel: GelShell's default; other counts take the symbolic path.
constexpr int THICKNESS_POINTS = 2;
constexpr int PAIRS[3][2] = {{0, 0}, {0, 1}, {1, 1}};  // the frame components s of a symmetric 2x2

struct Frame { double T[2][3], N[3], W[3]; };

static void MakeFrame(const double * N, const double * weingarten, Frame & frame) {
  for (int i = 0; i < 3; i++) frame.N[i] = N[i];
  int k = 0;  // the coordinate axis least aligned with N gives a well-conditioned T1
  for (int i = 1; i < 3; i++) if (fabs(N[i]) < fabs(N[k])) k = i;
  double e[3] = {0, 0, 0}; e[k] = 1;
  double t1[3] = {N[1]*e[2] - N[2]*e[1], N[2]*e[0] - N[0]*e[2], N[0]*e[1] - N[1]*e[0]};
  double norm = sqrt(t1[0]*t1[0] + t1[1]*t1[1] + t1[2]*t1[2]);
  for (int i = 0; i < 3; i++) frame.T[0][i] = t1[i] / norm;
  const double * b = frame.T[0];
  double t2[3] = {N[1]*b[2] - N[2]*b[1], N[2]*b[0] - N[0]*b[2], N[0]*b[1] - N[1]*b[0]};  // N x T1
  for (int i = 0; i < 3; i++) frame.T[1][i] = t2[i];
  // the symbolic forms symmetrise the Weingarten map (curved elements give it a small skew part)
  for (int s = 0; s < 3; s++) {
    double v = 0;
    for (int i = 0; i < 3; i++) for (int j = 0; j < 3; j++)
      v += frame.T[PAIRS[s][0]][i] * 0.5 * (weingarten[3*i+j] + weingarten[3*j+i]) * frame.T[PAIRS[s][1]][j];
    frame.W[s] = v;
  }
}

// unit normal of the deformed surface as a function of r[0..5]
template <typename T>
void DeformedNormal(const double * r, const Frame & frame, T * n) {
  T f[2][3];
  for (int a = 0; a < 2; a++)
    for (int i = 0; i < 3; i++) f[a][i] = T(frame.T[a][i] + r[3*a+i], 3*a+i);
  T c[3] = {f[0][1]*f[1][2] - f[0][2]*f[1][1], f[0][2]*f[1][0] - f[0][0]*f[1][2], f[0][0]*f[1][1] - f[0][1]*f[1][0]};
  T inverse_norm = 1.0 / sqrt(c[0]*c[0] + c[1]*c[1] + c[2]*c[2]);
  for (int i = 0; i < 3; i++) n[i] = c[i] * inverse_norm;
}

// S (3 values) and its rows dS/dr of the reduction's Jacobian
template <int NR>
void Curvature(const double * r, const Frame & frame, const AutoDiffDiff<6> * n, double * S, double (*dS)[NR]) {
  double nN = 0, dnN[6] = {0, 0, 0, 0, 0, 0};
  for (int i = 0; i < 3; i++) {
    nN += n[i].Value() * frame.N[i];
    for (int j = 0; j < 6; j++) dnN[j] += n[i].DValue(j) * frame.N[i];
  }
  for (int s = 0; s < 3; s++) {
    double v = nN * frame.W[s];
    for (int j = 0; j < NR; j++) dS[s][j] = 0;
    for (int j = 0; j < 6; j++) dS[s][j] = dnN[j] * frame.W[s];
    for (int i = 0; i < 3; i++) {
      double h = r[6 + 3*i + s];
      v -= n[i].Value() * h;
      for (int j = 0; j < 6; j++) dS[s][j] -= n[i].DValue(j) * h;
      dS[s][6 + 3*i + s] = -n[i].Value();
    }
    S[s] = v;
  }
}

// H += sum_s dphi_dS[s] d2S_s/dr2
template <int NR>
void AddCurvatureHessian(const double * dphi_dS, const double * r, const Frame & frame, const AutoDiffDiff<6> * n,
                         double (*H)[NR]) {
  for (int s = 0; s < 3; s++) {
    double g = dphi_dS[s];
    for (int j = 0; j < 6; j++)
      for (int l = 0; l < 6; l++) {
        double d2 = 0;
        for (int i = 0; i < 3; i++) d2 += n[i].DDValue(j, l) * (frame.N[i] * frame.W[s] - r[6 + 3*i + s]);
        H[j][l] += g * d2;
      }
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 6; j++) {
        H[j][6 + 3*i + s] -= g * n[i].DValue(j);
        H[6 + 3*i + s][j] -= g * n[i].DValue(j);
      }
  }
}

// ------------------------------------------------------------------------------------------ area
// psi = t/2 sum_q w_q det A_q W'(F_q, mu): GelShell._kinematics's "psi".
struct AreaModel {
  static constexpr int NR = 15 + THICKNESS_POINTS, NY = 6 + THICKNESS_POINTS;
  static constexpr int CURVATURE = 3;  // S is y[3..5]
  static constexpr int NGEOMETRY = 14;  // N, Weingarten map (9), Nv, mu
  static constexpr bool ON_ELEMENT_BOUNDARY = false;
  double thickness, lam0, chi, zeta[THICKNESS_POINTS], weight[THICKNESS_POINTS];

  struct Point {
    Frame frame;
    double shifter_inverse[THICKNESS_POINTS][2][2], shifter_inverse_det[THICKNESS_POINTS];
    double layer_weight[THICKNESS_POINTS], Nv, mu;
  };

  void MakePoint(const double * geometry, Point & p) const {
    MakeFrame(geometry, geometry + 3, p.frame);
    for (int q = 0; q < THICKNESS_POINTS; q++) {
      double z = zeta[q];
      double A11 = 1 + z * p.frame.W[0], A12 = z * p.frame.W[1], A22 = 1 + z * p.frame.W[2];
      double det = A11 * A22 - A12 * A12;
      auto & Ainv = p.shifter_inverse[q];
      Ainv[0][0] = A22 / det; Ainv[0][1] = -A12 / det;
      Ainv[1][0] = -A12 / det; Ainv[1][1] = A11 / det;
      p.shifter_inverse_det[q] = 1 / det;
      p.layer_weight[q] = 0.5 * thickness * weight[q] * det;
    }
    p.Nv = geometry[12]; p.mu = geometry[13];
  }

  void ExtraRows(const Point &, FlatArray<FlatMatrix<double, ColMajor>> extra, int ip, int dof, double * rows) const {
    for (int q = 0; q < THICKNESS_POINTS; q++) rows[q] = extra[q](ip, dof);
  }

  template <typename T>
  T Phi(const T * y, const Point & p) const {
    T det_a = y[0] * y[2] - y[1] * y[1];
    T ia11 = y[2] / det_a, ia12 = -y[1] / det_a, ia22 = y[0] / det_a;
    T Q[2][2] = {{ia11 * y[3] + ia12 * y[4], ia11 * y[4] + ia12 * y[5]},
                 {ia12 * y[3] + ia22 * y[4], ia12 * y[4] + ia22 * y[5]}};  // a^-1 S
    T lever = T(0.0);
    for (int q = 0; q < THICKNESS_POINTS; q++) lever = lever + y[6 + q];
    lever = lever * (1.0 / THICKNESS_POINTS);
    T sqrt_det_a = sqrt(det_a);
    double l2 = lam0 * lam0, l3 = l2 * lam0;
    T psi = T(0.0);
    for (int q = 0; q < THICKNESS_POINTS; q++) {
      T zl = zeta[q] * lever;
      T K[2][2] = {{1.0 + zl * Q[0][0], zl * Q[0][1]}, {zl * Q[1][0], 1.0 + zl * Q[1][1]}};
      const auto & Ainv = p.shifter_inverse[q];
      T M[2][2];
      for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) M[i][j] = K[i][0] * Ainv[0][j] + K[i][1] * Ainv[1][j];
      T trMaM = T(0.0);
      for (int j = 0; j < 2; j++)
        trMaM = trMaM + M[0][j] * (y[0] * M[0][j] + y[1] * M[1][j]) + M[1][j] * (y[1] * M[0][j] + y[2] * M[1][j]);
      T lam = y[6 + q];
      T detM = (K[0][0] * K[1][1] - K[0][1] * K[1][0]) * p.shifter_inverse_det[q];
      // W'(F, mu) = W(lam0 F, mu) / lam0^3 with W of FloryRehnerGel
      T I1 = l2 * (trMaM + lam * lam);
      T J = l3 * lam * detM * sqrt_det_a;
      T iJ = 1.0 / J;
      T W = p.Nv / 2 * (I1 - 3.0 - 2.0 * log(J)) + (J - 1.0) * log(1.0 - iJ) - chi * iJ - p.mu * (J - 1.0);
      psi = psi + p.layer_weight[q] / l3 * W;
    }
    return psi;
  }

  void Reduce(const double * r, const Point & p, AutoDiffDiff<6> * n, double * y, double (*J)[NR]) const {
    DeformedNormal(r, p.frame, n);
    double f[2][3];
    for (int a = 0; a < 2; a++) for (int i = 0; i < 3; i++) f[a][i] = p.frame.T[a][i] + r[3*a+i];
    for (int k = 0; k < NY; k++) for (int j = 0; j < NR; j++) J[k][j] = 0;
    for (int s = 0; s < 3; s++) {
      int a = PAIRS[s][0], b = PAIRS[s][1];
      y[s] = f[a][0]*f[b][0] + f[a][1]*f[b][1] + f[a][2]*f[b][2];
      for (int i = 0; i < 3; i++) { J[s][3*a+i] += f[b][i]; J[s][3*b+i] += f[a][i]; }
    }
    Curvature<NR>(r, p.frame, n, y + CURVATURE, J + CURVATURE);
    for (int q = 0; q < THICKNESS_POINTS; q++) { y[6+q] = r[15+q]; J[6+q][15+q] = 1; }
  }

  // sum_k phi'_k y_k'' of the metric a_ab = f_a . f_b (the curvature's part is common)
  void AddMetricHessian(const double * dphi, double (*H)[NR]) const {
    for (int i = 0; i < 3; i++) {
      H[i][i] += 2 * dphi[0];
      H[i][3+i] += dphi[1]; H[3+i][i] += dphi[1];
      H[3+i][3+i] += 2 * dphi[2];
    }
  }
};

// ------------------------------------------------------------------------------------------ edge
// m_nn theta + stiffness/2 theta^2 (GelShell._edge_energy with the linearised moment)
// m = -t^3/12 2G (cc + nu/(1-nu) tr(cc) P), cc = S - sqrt|f_1 x f_2| W,
// theta = acos(mu_def . avg_def) - acos(mu_ref . avg_ref) + omega . mu_ref.
struct EdgeModel {
  static constexpr int NR = 16, NY = 10;
  static constexpr int CURVATURE = 6;  // S is y[6..8]
  // N, Weingarten map (9), edge tangent, averaged normal (current, reference), penalty stiffness,
  // 2G, nu/(1-nu)
  static constexpr int NGEOMETRY = 24;
  static constexpr bool ON_ELEMENT_BOUNDARY = true;
  double thickness;

  struct Point {
    Frame frame;
    double avg[3], mu_ref[3], tau_in_frame[2], mu_in_frame[2], theta_ref, stiffness, G2, nu_ratio;
  };

  void MakePoint(const double * geometry, Point & p) const {
    MakeFrame(geometry, geometry + 3, p.frame);
    const double * N = geometry, * tau = geometry + 12, * avg = geometry + 15, * avg_ref = geometry + 18;
    double mu[3] = {N[1]*tau[2] - N[2]*tau[1], N[2]*tau[0] - N[0]*tau[2], N[0]*tau[1] - N[1]*tau[0]};
    for (int i = 0; i < 3; i++) { p.avg[i] = avg[i]; p.mu_ref[i] = mu[i]; }
    for (int a = 0; a < 2; a++) {
      p.tau_in_frame[a] = p.frame.T[a][0]*tau[0] + p.frame.T[a][1]*tau[1] + p.frame.T[a][2]*tau[2];
      p.mu_in_frame[a] = p.frame.T[a][0]*mu[0] + p.frame.T[a][1]*mu[1] + p.frame.T[a][2]*mu[2];
    }
    double along = tau[0]*avg_ref[0] + tau[1]*avg_ref[1] + tau[2]*avg_ref[2];
    double v[3], norm = 0;
    for (int i = 0; i < 3; i++) { v[i] = avg_ref[i] - along * tau[i]; norm += v[i]*v[i]; }
    norm = sqrt(norm);
    p.theta_ref = acos((mu[0]*v[0] + mu[1]*v[1] + mu[2]*v[2]) / norm);
    p.stiffness = geometry[21]; p.G2 = geometry[22]; p.nu_ratio = geometry[23];
  }

  void ExtraRows(const Point & p, FlatArray<FlatMatrix<double, ColMajor>> extra, int ip, int dof, double * rows) const {
    const auto & omega = extra[0];
    rows[0] = p.mu_ref[0] * omega(3*ip, dof) + p.mu_ref[1] * omega(3*ip+1, dof) + p.mu_ref[2] * omega(3*ip+2, dof);
  }

  template <typename T>
  T Phi(const T * y, const Point & p) const {
    T f[2][3];
    for (int a = 0; a < 2; a++) for (int i = 0; i < 3; i++) f[a][i] = p.frame.T[a][i] + y[3*a+i];
    T c[3] = {f[0][1]*f[1][2] - f[0][2]*f[1][1], f[0][2]*f[1][0] - f[0][0]*f[1][2], f[0][0]*f[1][1] - f[0][1]*f[1][0]};
    T c_norm = sqrt(c[0]*c[0] + c[1]*c[1] + c[2]*c[2]);
    T n[3];
    for (int i = 0; i < 3; i++) n[i] = c[i] / c_norm;
    T tau_def[3];
    for (int i = 0; i < 3; i++) tau_def[i] = f[0][i] * p.tau_in_frame[0] + f[1][i] * p.tau_in_frame[1];
    T tau_norm = sqrt(tau_def[0]*tau_def[0] + tau_def[1]*tau_def[1] + tau_def[2]*tau_def[2]);
    for (int i = 0; i < 3; i++) tau_def[i] = tau_def[i] / tau_norm;
    T mu_def[3] = {n[1]*tau_def[2] - n[2]*tau_def[1], n[2]*tau_def[0] - n[0]*tau_def[2], n[0]*tau_def[1] - n[1]*tau_def[0]};
    T along = tau_def[0]*p.avg[0] + tau_def[1]*p.avg[1] + tau_def[2]*p.avg[2];
    T v[3];
    for (int i = 0; i < 3; i++) v[i] = p.avg[i] - along * tau_def[i];
    T v_norm = sqrt(v[0]*v[0] + v[1]*v[1] + v[2]*v[2]);
    T theta = acos((mu_def[0]*v[0] + mu_def[1]*v[1] + mu_def[2]*v[2]) / v_norm) - p.theta_ref + y[9];
    T root = sqrt(c_norm);
    T cc[3];
    for (int s = 0; s < 3; s++) cc[s] = y[CURVATURE + s] - root * p.frame.W[s];
    const double * m = p.mu_in_frame;
    T cc_mm = m[0]*m[0]*cc[0] + 2.0*m[0]*m[1]*cc[1] + m[1]*m[1]*cc[2];
    T m_nn = (-thickness*thickness*thickness/12 * p.G2) * (cc_mm + p.nu_ratio * (cc[0] + cc[2]));
    return m_nn * theta + 0.5 * p.stiffness * theta * theta;
  }

  void Reduce(const double * r, const Point & p, AutoDiffDiff<6> * n, double * y, double (*J)[NR]) const {
    DeformedNormal(r, p.frame, n);
    for (int k = 0; k < NY; k++) for (int j = 0; j < NR; j++) J[k][j] = 0;
    for (int j = 0; j < 6; j++) { y[j] = r[j]; J[j][j] = 1; }
    Curvature<NR>(r, p.frame, n, y + CURVATURE, J + CURVATURE);
    y[9] = r[15]; J[9][15] = 1;
  }

  void AddMetricHessian(const double *, double (*)[NR]) const {}  // f enters phi linearly in y
};

// ------------------------------------------------------------------------ second-order jets
// A value with its gradient and the upper triangle of its Hessian in D variables: ngcore's
// AutoDiffDiff keeps the full D x D Hessian, so each product costs nearly twice the work; the
// point Hessians of the two energies (D = 8, 10) were a third of the tangent's assembly.
template <int D>
struct Jet2 {
  static constexpr int NH = D * (D + 1) / 2;
  double v = 0, g[D] = {}, h[NH] = {};  // h: rows of the upper triangle, (0,0), (0,1), ..., (1,1), ...

  Jet2() = default;
  Jet2(double value) : v(value) {}
  Jet2(double value, int variable) : v(value) { g[variable] = 1; }

  double Value() const { return v; }
  double DValue(int i) const { return g[i]; }

  // f(x) from f, f', f'' at x's value
  Jet2 Chain(double f, double df, double ddf) const {
    Jet2 r(f);
    for (int i = 0; i < D; i++) r.g[i] = df * g[i];
    for (int i = 0, k = 0; i < D; i++)
      for (int j = i; j < D; j++, k++) r.h[k] = df * h[k] + ddf * g[i] * g[j];
    return r;
  }
};

template <int D> Jet2<D> operator+ (const Jet2<D> & x, const Jet2<D> & y) {
  Jet2<D> r(x.v + y.v);
  for (int i = 0; i < D; i++) r.g[i] = x.g[i] + y.g[i];
  for (int k = 0; k < Jet2<D>::NH; k++) r.h[k] = x.h[k] + y.h[k];
  return r;
}
template <int D> Jet2<D> operator* (double a, const Jet2<D> & x) {
  Jet2<D> r(a * x.v);
  for (int i = 0; i < D; i++) r.g[i] = a * x.g[i];
  for (int k = 0; k < Jet2<D>::NH; k++) r.h[k] = a * x.h[k];
  return r;
}
template <int D> Jet2<D> operator* (const Jet2<D> & x, double a) { return a * x; }
template <int D> Jet2<D> operator- (const Jet2<D> & x) { return -1.0 * x; }
template <int D> Jet2<D> operator- (const Jet2<D> & x, const Jet2<D> & y) { return x + (-y); }
template <int D> Jet2<D> operator+ (const Jet2<D> & x, double a) { Jet2<D> r = x; r.v += a; return r; }
template <int D> Jet2<D> operator+ (double a, const Jet2<D> & x) { return x + a; }
template <int D> Jet2<D> operator- (const Jet2<D> & x, double a) { return x + (-a); }
template <int D> Jet2<D> operator- (double a, const Jet2<D> & x) { return (-x) + a; }
template <int D> Jet2<D> operator* (const Jet2<D> & x, const Jet2<D> & y) {
  Jet2<D> r(x.v * y.v);
  for (int i = 0; i < D; i++) r.g[i] = x.v * y.g[i] + y.v * x.g[i];
  for (int i = 0, k = 0; i < D; i++)
    for (int j = i; j < D; j++, k++)
      r.h[k] = x.v * y.h[k] + y.v * x.h[k] + x.g[i] * y.g[j] + x.g[j] * y.g[i];
  return r;
}
template <int D> Jet2<D> Inverse(const Jet2<D> & x) {
  double i = 1 / x.v;
  return x.Chain(i, -i * i, 2 * i * i * i);
}
template <int D> Jet2<D> operator/ (const Jet2<D> & x, const Jet2<D> & y) { return x * Inverse(y); }
template <int D> Jet2<D> operator/ (double a, const Jet2<D> & x) { return a * Inverse(x); }
template <int D> Jet2<D> operator/ (const Jet2<D> & x, double a) { return (1 / a) * x; }
template <int D> Jet2<D> sqrt(const Jet2<D> & x) {
  double s = std::sqrt(x.v);
  return x.Chain(s, 0.5 / s, -0.25 / (s * x.v));
}
template <int D> Jet2<D> log(const Jet2<D> & x) { return x.Chain(std::log(x.v), 1 / x.v, -1 / (x.v * x.v)); }
template <int D> Jet2<D> acos(const Jet2<D> & x) {
  double w = 1 - x.v * x.v, s = std::sqrt(w);
  return x.Chain(std::acos(x.v), -1 / s, -x.v / (w * s));
}

// ----------------------------------------------------------------------------- point derivatives
// phi(y(r)) and its derivatives in r at one point, through the reduced variables y
template <class Model>
struct PointEnergy {
  static constexpr int NR = Model::NR, NY = Model::NY;
  const Model & model;

  double Value(const double * r, const typename Model::Point & p) const {
    AutoDiffDiff<6> n[3];
    double y[NY], J[NY][NR];
    model.Reduce(r, p, n, y, J);
    return model.Phi(y, p);
  }

  double Gradient(const double * r, const typename Model::Point & p, double * g) const {
    AutoDiffDiff<6> n[3];
    double y[NY], J[NY][NR];
    model.Reduce(r, p, n, y, J);
    AutoDiff<NY> yd[NY];
    for (int k = 0; k < NY; k++) yd[k] = AutoDiff<NY>(y[k], k);
    AutoDiff<NY> phi = model.Phi(yd, p);
    ChainGradient(phi, J, g);
    return phi.Value();
  }

  double Hessian(const double * r, const typename Model::Point & p, double * g, double (*H)[NR]) const {
    AutoDiffDiff<6> n[3];
    double y[NY], J[NY][NR];
    model.Reduce(r, p, n, y, J);
    Jet2<NY> yd[NY];
    for (int k = 0; k < NY; k++) yd[k] = Jet2<NY>(y[k], k);
    Jet2<NY> phi = model.Phi(yd, p);
    ChainGradient(phi, J, g);
    double P[NY][NY];
    for (int k = 0, i = 0; k < NY; k++)
      for (int l = k; l < NY; l++, i++) P[k][l] = P[l][k] = phi.h[i];
    double PJ[NY][NR];  // phi'' J, then H = J^T phi'' J
    for (int k = 0; k < NY; k++)
      for (int j = 0; j < NR; j++) {
        double s = 0;
        for (int l = 0; l < NY; l++) s += P[k][l] * J[l][j];
        PJ[k][j] = s;
      }
    for (int i = 0; i < NR; i++)
      for (int j = 0; j < NR; j++) {
        double s = 0;
        for (int k = 0; k < NY; k++) s += J[k][i] * PJ[k][j];
        H[i][j] = s;
      }
    double dphi[NY];
    for (int k = 0; k < NY; k++) dphi[k] = phi.DValue(k);
    model.AddMetricHessian(dphi, H);
    AddCurvatureHessian<NR>(dphi + Model::CURVATURE, r, p.frame, n, H);
    return phi.Value();
  }

  template <typename AD>
  static void ChainGradient(const AD & phi, const double (*J)[NR], double * g) {
    for (int j = 0; j < NR; j++) {
      double s = 0;
      for (int k = 0; k < NY; k++) s += phi.DValue(k) * J[k][j];
      g[j] = s;
    }
  }
};

// ------------------------------------------------------------------------------------ integrator
template <class Model>
class KernelIntegrator : public BilinearFormIntegrator {
  static constexpr int NR = Model::NR;
  shared_ptr<DifferentialOperator> grad, hesse;
  Array<shared_ptr<DifferentialOperator>> extra;
  shared_ptr<CoefficientFunction> geometry;
  Model model;

  static shared_ptr<DifferentialOperator> TrialOperator(shared_ptr<CoefficientFunction> cf, const string & name) {
    auto proxy = dynamic_pointer_cast<ProxyFunction>(cf);
    if (!proxy || proxy->IsTestFunction())
      throw Exception(name + " must be a trial function (ProxyFunction)");
    return proxy->Evaluator();
  }

public:
  KernelIntegrator(shared_ptr<CoefficientFunction> agrad, shared_ptr<CoefficientFunction> ahesse,
                   py::list aextra, shared_ptr<CoefficientFunction> ageometry, Model amodel, size_t elements)
    : model(amodel), shapes(elements) {
    grad = TrialOperator(agrad, "grad");
    hesse = TrialOperator(ahesse, "hesse");
    if (grad->Dim() != 9 || hesse->Dim() != 27)
      throw Exception("grad must have 9 and hesse 27 components");
    for (auto e : aextra) extra.Append(TrialOperator(e.cast<shared_ptr<CoefficientFunction>>(), "extra"));
    if (extra.Size() != NR - 15)
      throw Exception("expected " + ToString(NR - 15) + " extra trial functions, got " + ToString(extra.Size()));
    if (ageometry->Dimension() != Model::NGEOMETRY)
      throw Exception("geometry must have " + ToString(Model::NGEOMETRY) + " components");
    geometry = ageometry;
  }

  VorB VB() const override { return BND; }
  xbool IsSymmetric() const override { return true; }
  string Name() const override { return "ShellKernelIntegrator"; }

  void CalcElementMatrix(const FiniteElement &, const ElementTransformation &, FlatMatrix<double>,
                         LocalHeap &) const override {
    throw Exception("the shell kernels are nonlinear: use AssembleLinearization");
  }

  // each_rule(mapped rule) for the element's rule, or for each edge's rule on the element boundary,
  // with the orders of NGSolve's SymbolicEnergy (2 * element order), so both paths integrate alike
  template <typename F>
  void ForEachRule(const FiniteElement & fel, const ElementTransformation & trafo, LocalHeap & lh, F && each_rule) const {
    if constexpr (!Model::ON_ELEMENT_BOUNDARY) {
      const IntegrationRule & ir = SelectIntegrationRule(trafo.GetElementType(), 2 * fel.Order());
      each_rule(trafo(ir, lh));
    } else {
      Facet2ElementTrafo facet_to_element(trafo.GetElementType(), BND);
      for (int k = 0; k < facet_to_element.GetNFacets(); k++) {
        HeapReset hr(lh);
        const IntegrationRule & facet_rule = SelectIntegrationRule(facet_to_element.FacetType(k), 2 * fel.Order());
        IntegrationRule & element_rule = facet_to_element(k, facet_rule, lh);
        each_rule(trafo(element_rule, lh));
      }
    }
  }

  // B at every point of an element, built at the element's first evaluation: building it from the
  // proxies' CalcMatrix (the surface Hessian of curved elements above all) took half of each energy
  // and residual. Kept in two blocks, each on the element dofs it reaches: the NU rows of u's
  // gradient and Hessian (u's dofs) and the NE rows of the extra unknowns (the thickness stretches'
  // or the hybrid rotation's dofs), NU (NE) rows per point, the element's rules in order; every
  // product with B then skips the zeros between the blocks.
  static constexpr int NU = 15, NE = NR - 15;
  struct ElementShapes { std::vector<double> Bu, Be; std::vector<int> u_columns, e_columns; int nd = -1; };
  mutable std::vector<ElementShapes> shapes;

  void CalcShapes(const FiniteElement & fel, const BaseMappedIntegrationRule & mir, FlatMatrix<double> B,
                  LocalHeap & lh) const {
    HeapReset hr(lh);
    int np = mir.Size(), nd = fel.GetNDof();
    FlatMatrix<double> geometry_values(np, Model::NGEOMETRY, lh);
    geometry->Evaluate(mir, geometry_values);
    FlatMatrix<double, ColMajor> grad_shapes(9 * np, nd, lh), hesse_shapes(27 * np, nd, lh);
    grad->CalcMatrix(fel, mir, grad_shapes, lh);
    hesse->CalcMatrix(fel, mir, hesse_shapes, lh);
    FlatArray<FlatMatrix<double, ColMajor>> extra_shapes(extra.Size(), lh);
    for (int e = 0; e < extra.Size(); e++) {
      new (&extra_shapes[e]) FlatMatrix<double, ColMajor>(extra[e]->Dim() * np, nd, lh);
      extra[e]->CalcMatrix(fel, mir, extra_shapes[e], lh);
    }
    for (int ip = 0; ip < np; ip++) {
      typename Model::Point p;
      model.MakePoint(&geometry_values(ip, 0), p);
      const Frame & frame = p.frame;
      double sym[3][9];  // Sym(T_a (x) T_b) for the pairs s
      for (int s = 0; s < 3; s++)
        for (int j = 0; j < 3; j++)
          for (int k = 0; k < 3; k++)
            sym[s][3*j+k] = 0.5 * (frame.T[PAIRS[s][0]][j] * frame.T[PAIRS[s][1]][k]
                                   + frame.T[PAIRS[s][1]][j] * frame.T[PAIRS[s][0]][k]);
      auto Bp = B.Rows(NR * ip, NR * (ip + 1));
      for (int d = 0; d < nd; d++) {
        for (int a = 0; a < 2; a++)
          for (int i = 0; i < 3; i++)
            Bp(3*a+i, d) = grad_shapes(9*ip + 3*i, d) * frame.T[a][0] + grad_shapes(9*ip + 3*i + 1, d) * frame.T[a][1]
                           + grad_shapes(9*ip + 3*i + 2, d) * frame.T[a][2];
        for (int i = 0; i < 3; i++)
          for (int s = 0; s < 3; s++) {
            double v = 0;
            for (int jk = 0; jk < 9; jk++) v += sym[s][jk] * hesse_shapes(27*ip + 9*i + jk, d);
            Bp(6 + 3*i + s, d) = v;
          }
        double rows[NR - 15];
        model.ExtraRows(p, extra_shapes, ip, d, rows);
        for (int k = 15; k < NR; k++) Bp(k, d) = rows[k - 15];
      }
    }
  }

  void FillShapes(const FiniteElement & fel, const ElementTransformation & trafo, LocalHeap & lh,
                  ElementShapes & cache) const {
    int nd = fel.GetNDof();
    std::vector<double> full;
    ForEachRule(fel, trafo, lh, [&](const BaseMappedIntegrationRule & mir) {
      size_t offset = full.size(), rows = NR * mir.Size();
      full.resize(offset + rows * nd);
      CalcShapes(fel, mir, FlatMatrix<double>(rows, nd, full.data() + offset), lh);
    });
    size_t points = full.size() / (NR * nd);
    FlatMatrix<double> all(NR * points, nd, full.data());
    auto keep = [&](int first, int count, std::vector<int> & columns, std::vector<double> & B) {
      columns.clear();
      for (int d = 0; d < nd; d++) {
        bool reached = false;
        for (size_t p = 0; p < points && !reached; p++)
          for (int k = first; k < first + count && !reached; k++) reached = all(NR * p + k, d) != 0.0;
        if (reached) columns.push_back(d);
      }
      size_t nc = columns.size();
      B.resize(points * count * nc);
      for (size_t p = 0; p < points; p++)
        for (int k = 0; k < count; k++)
          for (size_t c = 0; c < nc; c++) B[(p * count + k) * nc + c] = all(NR * p + first + k, columns[c]);
    };
    keep(0, NU, cache.u_columns, cache.Bu);
    keep(NU, NE, cache.e_columns, cache.Be);
    cache.nd = nd;
  }

  // the two blocks of B at the points of one rule (NU np x u columns, NE np x extra columns)
  struct RuleShapes {
    FlatMatrix<double> Bu, Be;
    FlatArray<int> u_columns, e_columns;
  };

  // each_rule(mir, shapes) for every rule of the element
  template <typename F>
  void ForEachRuleShapes(const FiniteElement & fel, const ElementTransformation & trafo, LocalHeap & lh,
                         F && each_rule) const {
    size_t element = trafo.GetElementNr();
    if (element >= shapes.size())
      throw Exception("shell kernel: element " + ToString(element) + " beyond the " + ToString(shapes.size())
                      + " elements it was built for");
    ElementShapes & cache = shapes[element];  // one thread per element in an assembly
    if (cache.nd != fel.GetNDof()) FillShapes(fel, trafo, lh, cache);
    FlatArray<int> u_columns(cache.u_columns.size(), cache.u_columns.data());
    FlatArray<int> e_columns(cache.e_columns.size(), cache.e_columns.data());
    size_t point = 0;  // points of the element's earlier rules
    ForEachRule(fel, trafo, lh, [&](const BaseMappedIntegrationRule & mir) {
      size_t np = mir.Size();
      each_rule(mir, RuleShapes{
          FlatMatrix<double>(NU * np, u_columns.Size(), cache.Bu.data() + NU * point * u_columns.Size()),
          FlatMatrix<double>(NE * np, e_columns.Size(), cache.Be.data() + NE * point * e_columns.Size()),
          u_columns, e_columns});
      point += np;
    });
  }

  // each_point(ip, weight, point data, r, Bu, Be) at every point of mir, Bu and Be its rows of the
  // rule's blocks; xu and xe the element vector on the blocks' columns
  template <typename F>
  void ForEachPoint(const BaseMappedIntegrationRule & mir, const RuleShapes & B, FlatVector<double> xu,
                    FlatVector<double> xe, LocalHeap & lh, F && each_point) const {
    int np = mir.Size();
    FlatMatrix<double> geometry_values(np, Model::NGEOMETRY, lh);
    geometry->Evaluate(mir, geometry_values);
    for (int ip = 0; ip < np; ip++) {
      typename Model::Point p;
      model.MakePoint(&geometry_values(ip, 0), p);
      FlatMatrix<double> Bu = B.Bu.Rows(NU * ip, NU * (ip + 1)), Be = B.Be.Rows(NE * ip, NE * (ip + 1));
      double r[NR];
      for (int k = 0; k < NU; k++) r[k] = InnerProduct(Bu.Row(k), xu);
      for (int k = 0; k < NE; k++) r[NU + k] = InnerProduct(Be.Row(k), xe);
      each_point(ip, mir[ip].GetWeight(), p, r, Bu, Be);
    }
  }

  static FlatVector<double> Gather(FlatVector<double> elx, FlatArray<int> columns, LocalHeap & lh) {
    FlatVector<double> x(columns.Size(), lh);
    for (size_t c = 0; c < columns.Size(); c++) x(c) = elx(columns[c]);
    return x;
  }

  void CalcLinearizedElementMatrix(const FiniteElement & fel, const ElementTransformation & trafo,
                                   FlatVector<double> elx, FlatMatrix<double> elmat,
                                   LocalHeap & lh) const override {
    HeapReset hr(lh);
    elmat = 0.0;
    PointEnergy<Model> energy{model};
    ForEachRuleShapes(fel, trafo, lh, [&](const BaseMappedIntegrationRule & mir, const RuleShapes & B) {
      int np = mir.Size(), cu = B.u_columns.Size(), ce = B.e_columns.Size();
      FlatMatrix<double> DuuBu(NU * np, cu, lh), DueBe(NU * np, ce, lh), DeeBe(NE * np, ce, lh);
      ForEachPoint(mir, B, Gather(elx, B.u_columns, lh), Gather(elx, B.e_columns, lh), lh,
                   [&](int ip, double weight, const typename Model::Point & p, const double * r,
                       FlatMatrix<double> Bu, FlatMatrix<double> Be) {
        double g[NR], H[NR][NR];
        energy.Hessian(r, p, g, H);
        FlatMatrix<double> D(NR, NR, &H[0][0]);
        D *= weight;
        // plain products: NGSolve's fast kernels
        DuuBu.Rows(NU * ip, NU * (ip + 1)) = D.Rows(0, NU).Cols(0, NU) * Bu;
        DueBe.Rows(NU * ip, NU * (ip + 1)) = D.Rows(0, NU).Cols(NU, NR) * Be;
        DeeBe.Rows(NE * ip, NE * (ip + 1)) = D.Rows(NU, NR).Cols(NU, NR) * Be;
      });
      // one matrix product per block and rule instead of one per point
      FlatMatrix<double> Kuu(cu, cu, lh), Kue(cu, ce, lh), Kee(ce, ce, lh);
      Kuu = Trans(B.Bu) * DuuBu;
      Kue = Trans(B.Bu) * DueBe;
      Kee = Trans(B.Be) * DeeBe;
      for (int i = 0; i < cu; i++) {
        for (int j = 0; j < cu; j++) elmat(B.u_columns[i], B.u_columns[j]) += Kuu(i, j);
        for (int j = 0; j < ce; j++) {
          elmat(B.u_columns[i], B.e_columns[j]) += Kue(i, j);
          elmat(B.e_columns[j], B.u_columns[i]) += Kue(i, j);
        }
      }
      for (int i = 0; i < ce; i++)
        for (int j = 0; j < ce; j++) elmat(B.e_columns[i], B.e_columns[j]) += Kee(i, j);
    });
  }

  void ApplyElementMatrix(const FiniteElement & fel, const ElementTransformation & trafo,
                          const FlatVector<double> elx, FlatVector<double> ely, void *,
                          LocalHeap & lh) const override {
    HeapReset hr(lh);
    ely = 0.0;
    PointEnergy<Model> energy{model};
    ForEachRuleShapes(fel, trafo, lh, [&](const BaseMappedIntegrationRule & mir, const RuleShapes & B) {
      FlatVector<double> yu(B.u_columns.Size(), lh), ye(B.e_columns.Size(), lh);
      yu = 0.0;
      ye = 0.0;
      ForEachPoint(mir, B, Gather(elx, B.u_columns, lh), Gather(elx, B.e_columns, lh), lh,
                   [&](int, double weight, const typename Model::Point & p, const double * r,
                       FlatMatrix<double> Bu, FlatMatrix<double> Be) {
        double g[NR];
        energy.Gradient(r, p, g);
        yu += weight * Trans(Bu) * FlatVector<double>(NU, g);
        ye += weight * Trans(Be) * FlatVector<double>(NE, g + NU);
      });
      for (size_t c = 0; c < B.u_columns.Size(); c++) ely(B.u_columns[c]) += yu(c);
      for (size_t c = 0; c < B.e_columns.Size(); c++) ely(B.e_columns[c]) += ye(c);
    });
  }

  double Energy(const FiniteElement & fel, const ElementTransformation & trafo, FlatVector<double> elx,
                LocalHeap & lh) const override {
    HeapReset hr(lh);
    double sum = 0;
    PointEnergy<Model> energy{model};
    ForEachRuleShapes(fel, trafo, lh, [&](const BaseMappedIntegrationRule & mir, const RuleShapes & B) {
      ForEachPoint(mir, B, Gather(elx, B.u_columns, lh), Gather(elx, B.e_columns, lh), lh,
                   [&](int, double weight, const typename Model::Point & p, const double * r, FlatMatrix<double>,
                       FlatMatrix<double>) { sum += weight * energy.Value(r, p); });
    });
    return sum;
  }
};

PYBIND11_MODULE(_shell_kernels, m) {
  py::module::import("ngsolve");  // registers BilinearFormIntegrator's Python type
  m.attr("THICKNESS_POINTS") = THICKNESS_POINTS;
  using Area = KernelIntegrator<AreaModel>;
  using Edge = KernelIntegrator<EdgeModel>;
  py::class_<Area, shared_ptr<Area>, BilinearFormIntegrator>(m, "ShellArea")
    .def(py::init([](shared_ptr<CoefficientFunction> grad, shared_ptr<CoefficientFunction> hesse, py::list lams,
                     shared_ptr<CoefficientFunction> geometry, double thickness, double lam0, double chi,
                     py::list zetas, py::list weights, size_t elements) {
           if (py::len(lams) != THICKNESS_POINTS || py::len(zetas) != THICKNESS_POINTS || py::len(weights) != THICKNESS_POINTS)
             throw Exception("the area kernel has " + ToString(THICKNESS_POINTS) + " thickness points");
           AreaModel model;
           model.thickness = thickness; model.lam0 = lam0; model.chi = chi;
           for (int q = 0; q < THICKNESS_POINTS; q++) {
             model.zeta[q] = zetas[q].cast<double>();
             model.weight[q] = weights[q].cast<double>();
           }
           return make_shared<Area>(grad, hesse, lams, geometry, model, elements);
         }),
         py::arg("grad"), py::arg("hesse"), py::arg("lams"), py::arg("geometry"), py::arg("thickness"),
         py::arg("lam0"), py::arg("chi"), py::arg("zetas"), py::arg("weights"), py::arg("elements"));
  py::class_<Edge, shared_ptr<Edge>, BilinearFormIntegrator>(m, "ShellEdge")
    .def(py::init([](shared_ptr<CoefficientFunction> grad, shared_ptr<CoefficientFunction> hesse,
                     shared_ptr<CoefficientFunction> omega, shared_ptr<CoefficientFunction> geometry, double thickness,
                     size_t elements) {
           EdgeModel model;
           model.thickness = thickness;
           py::list extra;
           extra.append(omega);
           return make_shared<Edge>(grad, hesse, extra, geometry, model, elements);
         }),
         py::arg("grad"), py::arg("hesse"), py::arg("omega"), py::arg("geometry"), py::arg("thickness"),
         py::arg("elements"));
}
