#pragma once
// Answers to commands (command_reply_t on CONTROLLER_REPLY and HARDWARE_REPLY): one reply per
// command taken or refused, carrying the command's channel, utime and seq, so the sender matches
// the answer to its request (client/ does) instead of reading the replier's status text.

#include <cstdint>
#include <deque>
#include <exception>
#include <sirupp/command_reply_t.hpp>
#include <string>
#include <utility>

#include "core/bus.hpp"

namespace sirupp::core {

// What a replier knows after handling a command: the move it started (-1: none) and the seq of
// the status it sent last (-1: none), which shows the command's effect.
struct ReplyFacts {
  int64_t move_id = -1;
  int64_t status_seq = -1;
};

// The reply to a request that came on `request_channel` (full name) with `request_utime` and
// `request_seq`: accepted when `error` is empty, refused with `error` otherwise. utime is the
// replier's wall clock.
sirupp::command_reply_t MakeReply(const std::string& sender, const std::string& request_channel,
                                  int64_t request_utime, int64_t request_seq,
                                  const std::string& error, const ReplyFacts& facts);

// True when `reply` answers the request sent on `request_channel` (full name) with this utime
// and seq.
bool RepliesTo(const sirupp::command_reply_t& reply, const std::string& request_channel,
               int64_t request_utime, int64_t request_seq);

// Sends one reply per handled command on one channel, with its own seq counter.
//
// A request that repeats the channel, utime and seq of one answered in the last kResendWindowS
// (and of the last kRemembered) is a resend: a client that heard no reply sends the same message
// again (UDP multicast drops datagrams when a receiver falls behind). It gets the first reply
// again, and the command is not carried out twice. Requests with utime 0 (hand-made messages
// that leave the field unset) are always carried out.
class Replier {
 public:
  // `channel`: without the rig prefix (Channels::controller_reply, ...). `sender`: the process.
  Replier(Bus& bus, std::string channel, std::string sender)
      : bus_(bus), channel_(std::move(channel)), sender_(std::move(sender)) {}

  // Runs handle(). If it returns, replies "accepted"; if it throws, replies "refused" with the
  // exception's text and rethrows (the bus counts the message as rejected). facts() is asked
  // after handle(), so it sees the move started and the status sent.
  template <class Msg, class Handle, class Facts>
  void Answer(const Msg& request, const ReceiveInfo& info, Handle&& handle, Facts&& facts) {
    if (AnswerAgain(info.channel, request.utime, request.seq)) return;
    try {
      handle();
    } catch (const std::exception& error) {
      Send(info.channel, request.utime, request.seq, error.what(), facts());
      throw;
    }
    Send(info.channel, request.utime, request.seq, "", facts());
  }

  void Send(const std::string& request_channel, int64_t request_utime, int64_t request_seq,
            const std::string& error, const ReplyFacts& facts);

  static constexpr double kResendWindowS = 30.0;
  static constexpr size_t kRemembered = 64;

 private:
  // Sends the reply again when this request was answered already; false when it was not.
  bool AnswerAgain(const std::string& request_channel, int64_t request_utime, int64_t request_seq);

  struct Sent {
    sirupp::command_reply_t reply;
    int64_t steady_us = 0;
  };
  Bus& bus_;
  std::string channel_;
  std::string sender_;
  int64_t seq_ = 0;
  std::deque<Sent> sent_;  // the last kRemembered replies, oldest first
};

}  // namespace sirupp::core
