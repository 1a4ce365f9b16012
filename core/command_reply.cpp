#include "core/command_reply.hpp"

#include "core/translate.hpp"

namespace sirupp::core {

sirupp::command_reply_t MakeReply(const std::string& sender, const std::string& request_channel,
                                  int64_t request_utime, int64_t request_seq,
                                  const std::string& error, const ReplyFacts& facts) {
  CommandReply reply;
  reply.utime = WallMicros();
  reply.sender = sender;
  reply.request_channel = request_channel;
  reply.request_utime = request_utime;
  reply.request_seq = request_seq;
  reply.accepted = error.empty();
  reply.error = error;
  reply.move_id = error.empty() ? facts.move_id : -1;
  reply.status_seq = facts.status_seq;
  return ToMessage(reply);
}

bool RepliesTo(const sirupp::command_reply_t& reply, const std::string& request_channel,
               int64_t request_utime, int64_t request_seq) {
  return reply.request_channel == request_channel && reply.request_utime == request_utime &&
         reply.request_seq == request_seq;
}

void Replier::Send(const std::string& request_channel, int64_t request_utime, int64_t request_seq,
                   const std::string& error, const ReplyFacts& facts) {
  sirupp::command_reply_t reply =
      MakeReply(sender_, request_channel, request_utime, request_seq, error, facts);
  reply.seq = seq_++;
  bus_.Publish(channel_, reply);
  if (request_utime == 0) return;
  if (sent_.size() >= kRemembered) sent_.pop_front();
  sent_.push_back(Sent{reply, SteadyMicros()});
}

bool Replier::AnswerAgain(const std::string& request_channel, int64_t request_utime,
                          int64_t request_seq) {
  if (request_utime == 0) return false;
  const int64_t now = SteadyMicros();
  for (auto it = sent_.rbegin(); it != sent_.rend(); ++it) {
    if (now - it->steady_us > static_cast<int64_t>(kResendWindowS * 1e6)) break;
    if (!RepliesTo(it->reply, request_channel, request_utime, request_seq)) continue;
    sirupp::command_reply_t again = it->reply;
    again.utime = WallMicros();
    again.seq = seq_++;
    bus_.Publish(channel_, again);
    return true;
  }
  return false;
}

}  // namespace sirupp::core
