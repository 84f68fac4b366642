// The paper's path as written: the address maps read back (glGetTextureImage)
// and scattered on the CPU, with the CPU twin of crater_rim.comp. Kept as the
// reference the GPU scatter must match bit for bit.
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>

#include <crumple/deform/passes.h>

namespace crumple::deform {

namespace {
// The CPU twin of crater_rim.comp (the read-back path must give the same maps).
void craterRimsCpu(std::vector<float>& out, const std::vector<float>& old, int res, GLint box[4]) {
  if (box[2] < box[0]) return;
  const int ring = craterRing(box[2] - box[0] + 1, box[3] - box[1] + 1);
  const float kFixed = 1048576.0f;
  auto dented = [&](int x, int y) { return out[size_t(y) * res + x] < old[size_t(y) * res + x]; };
  const int x0 = std::max(box[0] - ring, 0), y0 = std::max(box[1] - ring, 0);
  const int x1 = std::min(box[2] + ring, res - 1), y1 = std::min(box[3] + ring, res - 1);
  uint32_t volumeSum = 0, weightSum = 0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const size_t i = size_t(y) * res + x;
      if (out[i] < old[i]) volumeSum += static_cast<uint32_t>((old[i] - out[i]) * kFixed + 0.5f);
    }
  std::vector<float> weight(size_t(x1 - x0 + 1) * (y1 - y0 + 1), -1.0f);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      if (dented(x, y)) continue;
      float best = float(ring) + 1.0f;
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dx = -ring; dx <= ring; ++dx) {
          const int qx = x + dx, qy = y + dy;
          if (qx < box[0] || qy < box[1] || qx > box[2] || qy > box[3]) continue;
          const float d = std::sqrt(float(dx * dx + dy * dy));
          if (d < best && dented(qx, qy)) best = d;
        }
      if (best > float(ring)) continue;
      const float w = 1.0f - best / float(ring + 1);
      weight[size_t(y - y0) * (x1 - x0 + 1) + (x - x0)] = w;
      weightSum += static_cast<uint32_t>(w * kFixed + 0.5f);
    }
  const float volume = float(volumeSum) / kFixed, weights = std::max(float(weightSum) / kFixed, 1e-6f);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const float w = weight[size_t(y - y0) * (x1 - x0 + 1) + (x - x0)];
      if (w < 0) continue;
      const size_t i = size_t(y) * res + x;
      out[i] = std::min(old[i] + volume * w / weights, 1.0f);
    }
  box[0] = x0;
  box[1] = y0;
  box[2] = x1;
  box[3] = y1;
}
}  // namespace

void ReadbackUpdate::run(const SideUpdate& u, const AddressPasses& passes, const gl::Texture2D& height,
                         bool craterRims, const Scratch& scratch, gl::Buffer& region, const PhaseMark& phase) {
  const size_t px = static_cast<size_t>(passes.size()) * passes.size();
  const bool tangent = u.tangent != TangentMode::None;
  ca_.resize(px * 2);
  da_.resize(px);
  cb_.resize(px * 2);
  db_.resize(px);
  na_.resize(tangent ? px * 4 : 0);
  // The address maps come back with glGetTextureImage on the attached
  // textures: on NVIDIA's driver glReadPixels of float targets took
  // 1 s at 512 (0.8 us a pixel) where this takes a few ms.
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  passes.addressX(u.side).download(GL_RG, GL_FLOAT, ca_.data(), ca_.size() * sizeof(float));
  passes.depthX(u.side).download(GL_RED, GL_FLOAT, da_.data(), da_.size() * sizeof(float));
  if (tangent) passes.normalX(u.side).download(GL_RGBA, GL_FLOAT, na_.data(), na_.size() * sizeof(float));
  passes.addressOther(u.side).download(GL_RG, GL_FLOAT, cb_.data(), cb_.size() * sizeof(float));
  passes.depthOther(u.side).download(GL_RED, GL_FLOAT, db_.data(), db_.size() * sizeof(float));
  phase("read address maps");
  const int res = u.resolution;
  std::vector<float> h(static_cast<size_t>(res) * res);
  height.download(GL_RED, GL_FLOAT, h.data(), h.size() * sizeof(float));
  phase("height map download");
  std::vector<float> out = h;
  GLint box[4];
  scatter(u, passes, h, craterRims, out, box);
  phase("cpu scatter");
  std::vector<GLuint> bits(out.size());
  std::memcpy(bits.data(), out.data(), out.size() * sizeof(float));
  for (size_t i = 0; i < out.size(); ++i)
    if (out[i] == h[i]) bits[i] = kUntouched;
  glNamedBufferSubData(scratch.buffer->id(), static_cast<GLintptr>(scratch.offset) * sizeof(GLuint),
                       static_cast<GLsizeiptr>(bits.size() * sizeof(GLuint)), bits.data());
  region.upload(static_cast<size_t>(u.side) * 4 * sizeof(GLint), 4 * sizeof(GLint), box);
  phase("upload");
}

void ReadbackUpdate::scatter(const SideUpdate& u, const AddressPasses& passes, const std::vector<float>& h,
                             bool craterRims, std::vector<float>& out, GLint box[4]) {
  const size_t px = static_cast<size_t>(passes.size()) * passes.size();
  const bool tangent = u.tangent != TangentMode::None;
  const int res = u.resolution;
  box[0] = box[1] = INT_MAX;
  box[2] = box[3] = -1;
  for (size_t i = 0; i < px; ++i) {
    if (ca_[i * 2] < 0.0f || cb_[i * 2] < 0.0f) continue;
    float dD = db_[i] - da_[i];
    if (!(dD > 0.0f)) continue;
    dD = std::min(dD, u.pushDepth);  // an overlap beyond X's advance (and the bumps) was there before the push
    if (tangent) {
      const float c =
          std::abs(glm::dot(glm::normalize(glm::vec3(na_[i * 4], na_[i * 4 + 1], na_[i * 4 + 2])), u.viewNormal));
      dD = u.tangent == TangentMode::Multiply ? dD * c : dD / std::max(c, u.tangentFloor);
    }
    const int tx = std::clamp(static_cast<int>(std::floor(ca_[i * 2] * static_cast<float>(res))), 0, res - 1);
    const int ty = std::clamp(static_cast<int>(std::floor(ca_[i * 2 + 1] * static_cast<float>(res))), 0, res - 1);
    const size_t t = static_cast<size_t>(ty) * res + tx;
    const float drop = dD * u.depthToHeight;  // rounded, then subtracted: as the GPU's dent_update.comp
    const float h2 = std::clamp(h[t] - drop, 0.0f, 1.0f);
    if (!(h2 < h[t])) continue;
    out[t] = std::min(out[t], h2);
    box[0] = std::min(box[0], tx);
    box[1] = std::min(box[1], ty);
    box[2] = std::max(box[2], tx);
    box[3] = std::max(box[3], ty);
  }
  if (craterRims && box[2] >= box[0]) craterRimsCpu(out, h, res, box);  // grows the box by the ring itself
}

}  // namespace crumple::deform
